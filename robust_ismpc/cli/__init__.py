"""``ismpc`` command line (:func:`main`): the only package that parses arguments or prints."""

from .args import build_parser
from .entry import main

__all__ = ["build_parser", "main"]
