"""The ``dexpush`` command line (:func:`main`), its argument types and its configuration files."""

from dexpush.cli.main import main

__all__ = ["main"]
