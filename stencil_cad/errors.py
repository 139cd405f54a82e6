"""Errors a user can fix: each carries a one-line message naming the problem and the fix."""

from __future__ import annotations


class UserError(Exception):
    """A problem with the user's input; the CLI prints it on one line and exits with code 2."""


class ImageError(UserError):
    """The input image is missing, unreadable or unsuitable."""


class ConfigError(UserError):
    """The config file is missing, malformed or has a bad value."""


class OutputError(UserError):
    """The output folder cannot be written as asked."""
