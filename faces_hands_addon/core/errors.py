# SPDX-License-Identifier: GPL-3.0-or-later
"""Errors that describe bad input in words a user can act on."""


class UserError(Exception):
    """Bad input (a file, a mesh, a parameter). The message is shown as is, in one line, with no
    traceback: say what is wrong and what to do about it."""


class InputWarning(UserWarning):
    """Input taken after a correction the user should know of (a preset's value clamped into its range):
    the message says what was changed, where, and to what. Operators report it as a warning; the command
    line prints it."""
