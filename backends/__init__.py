"""Backends, one subpackage each, installed as ``neurovpr.backends.<name>``.

The registry finds them through the ``neurovpr.backends`` entry point; nothing else
imports them.
"""
