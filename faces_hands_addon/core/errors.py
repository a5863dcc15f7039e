# SPDX-License-Identifier: GPL-3.0-or-later
"""Errors that describe bad input in words a user can act on."""


class UserError(Exception):
    """Bad input (a file, a mesh, a parameter). The message is shown as is, in one line, with no
    traceback: say what is wrong and what to do about it."""
