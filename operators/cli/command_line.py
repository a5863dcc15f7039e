# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``faces_hands`` command line: ``blender -b -c faces_hands <subcommand> ...`` and ``./fh``.

Both call :func:`main` with the arguments after the command name. The subcommands come from the subsystem
packages (``operators.COMMANDS``); each exposes ``NAME``, ``HELP``, ``add_arguments(parser)`` and
``run(args, progress) -> int``.
Bad input exits non-zero with one line ``faces_hands: error: ...`` (no traceback) and writes nothing;
``--debug`` shows the traceback of unexpected errors.
"""
from __future__ import annotations

import argparse
import sys
import time
import traceback

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.foreign_files import check_path
from .interrupts import Terminated, clear, interruptible, private_temp_root, raise_pending
from ..adapters.outputs import ledger_mark, written_since
from ..adapters.paths import write_session_bytecode


class CommandLineError(Exception):
    """Raised instead of argparse's print-usage-and-exit, so the message stays one line."""


def _interrupt_report(error: KeyboardInterrupt, mark: int) -> str:
    files = written_since(mark)
    what = "terminated" if isinstance(error, Terminated) else "interrupted"
    if not files:
        return f"faces_hands: {what}; nothing was written"
    shown = ", ".join(str(p) for p in files[:20]) + (f" and {len(files) - 20} more" if len(files) > 20 else "")
    return f"faces_hands: {what}; written before that: {shown} (nothing else was written)"


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # noqa: D401 - argparse API
        raise CommandLineError(f"{message} (see: {self.prog} --help)")

    def exit(self, status=0, message=None):
        if message:
            print(message, file=sys.stderr, end="")
        raise SystemExit(status)


class Progress:
    """Prints ``[ 42%] message`` lines on stderr for long work (the CLI's progress bar): every 5 % and
    whenever the message changes, never the same line twice."""

    def __init__(self, quiet: bool = False):
        self.quiet = quiet
        self._last = -1.0
        self._message = ""

    def __call__(self, fraction: float, message: str = "") -> None:
        raise_pending()                     # an interrupt a C callback swallowed (common.interrupts)
        if self.quiet:
            return
        percent = max(0.0, min(1.0, fraction)) * 100.0
        new_message = bool(message) and message != self._message
        if percent - self._last >= 5.0 or (percent >= 100.0 > self._last) or new_message:
            print(f"[{percent:3.0f}%] {message}", file=sys.stderr, flush=True)
            self._last, self._message = percent, message or self._message


def _subcommands():
    from .. import COMMANDS
    return COMMANDS


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="faces_hands", description=(
        "Faces & Hands batch tools: build muscle face rigs, bake shape keys, speak text, render "
        "contact sheets. Run '<subcommand> --help' for details."))
    parser.add_argument("--debug", action="store_true", help="show tracebacks of unexpected errors")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    subparsers = parser.add_subparsers(dest="command", metavar="<subcommand>", parser_class=_Parser)
    for module in _subcommands():
        sub = subparsers.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.add_arguments(sub)
        sub.set_defaults(_run=module.run, _inputs=tuple(getattr(module, "INPUTS", ())),
                         _input_words=dict(getattr(module, "INPUT_WORDS", {})))
    return parser


def check_arguments(args) -> None:
    """Refuse before any work: an option given as an empty string (``--mesh ''`` must not mean 'the
    default'), and an input file (the command's ``INPUTS``; ``default`` names the built-in data, and the
    command's ``INPUT_WORDS`` other built-ins such as ``--rig mask``) that is missing, a folder, a symlink
    loop, unreadable or empty."""
    for name, value in vars(args).items():
        if isinstance(value, str) and not name.startswith("_") and not value.strip():
            raise UserError(f"--{name.replace('_', '-')} is empty; give a value or leave the option out")
    for name in args._inputs:
        value = getattr(args, name, None)
        if value is not None and value != "default" and value not in args._input_words.get(name, ()):
            check_path(value, f"--{name.replace('_', '-')}")


def main(argv: list[str] | None = None) -> int:
    """Run one subcommand; returns the process exit code. Unless interrupted, the modules the run loaded get
    their bytecode written (``paths.write_session_bytecode``), so the next run starts faster."""
    code = _run_command(argv)
    if code not in (130, 143):
        write_session_bytecode()
    return code


def _run_command(argv: list[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    debug = "--debug" in argv
    mark = ledger_mark()
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help()
            return 2
        check_arguments(args)
        started = time.perf_counter()
        with interruptible(), private_temp_root():
            code = args._run(args, Progress(quiet=args.quiet))
        if not args.quiet:
            print(f"done in {time.perf_counter() - started:.1f} s", file=sys.stderr)
        return int(code or 0)
    except (UserError, CommandLineError) as error:
        print(f"faces_hands: error: {error}", file=sys.stderr)
        return 2 if isinstance(error, CommandLineError) else 1
    except KeyboardInterrupt as error:
        clear()
        print(_interrupt_report(error, mark), file=sys.stderr)
        return 143 if isinstance(error, Terminated) else 130
    except SystemExit as exit_request:
        return int(exit_request.code or 0)
    except Exception as error:  # an unexpected error is a bug: say so in one line
        if debug:
            traceback.print_exc()
        print(f"faces_hands: internal error: {type(error).__name__}: {error} "
              f"(run with --debug for the traceback)", file=sys.stderr)
        return 3


def blender_cli_entry(argv):
    """``bpy.utils.register_cli_command`` callback: ``blender -b -c faces_hands ...``."""
    return main(list(argv))
