"""Hardware specifications (one TOML file per target), shipped as package data."""
