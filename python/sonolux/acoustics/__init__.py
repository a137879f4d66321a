"""Acoustic analysis in Python: closed-form theory (``theory``) that traced results are checked
against. The tracing itself is the Rust core's."""
