"""Errors a user can cause and fix: commands print the message as one line and exit 2."""


class UserError(Exception):
    """A mistake in what the user asked for (bad value, rejected pose, unreadable file)."""


class PoseRejected(UserError):
    """The placement lasers say the structure cannot stand at this pose."""
