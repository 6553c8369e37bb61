"""The ``neurovpr`` command line."""
