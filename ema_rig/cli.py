"""The ``ema-rig`` command line.

Each sub-command lives in ``ema_rig.commands.<name>`` with ``add_arguments(parser)`` and
``run(args) -> int``; this module only builds the parser and turns errors into one line on
stderr and a non-zero exit code.

Exit codes
----------
0  success
1  bad input or failed identification (one line ``error: <file>: <what is wrong>`` on stderr)
2  command-line usage error (argparse)
3  campaign finished with some failed measurements (partial failure)
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import os
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from . import _atomic
from ._text import inert
from ._version import version
from .errors import EmaRigError

EXIT_OK = 0
EXIT_ERROR = 1
EXIT_USAGE = 2
EXIT_PARTIAL = 3

COMMANDS: dict[str, str] = {
    "inspect": "list every dataset of a UFF file",
    "stabilization": "draw the PolyMAX stabilization chart",
    "modes": "automatically selected physical modes",
    "calibrate": "k_MS from a steel-disk measurement",
    "stiffness": "bearing stiffness k_TB from the housing mode",
    "campaign": "a whole campaign: table, plots, report",
    "simulate": "write a synthetic rig measurement (UFF58)",
    "frf": "FRFs and coherence (UFF58) from force and response time histories",
    "demo": "run the bundled campaign in data/ end to end",
}


class _VersionAction(argparse.Action):
    """``--version``: print the version and exit (looked up only when asked: importlib.metadata is slow)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str = "show the version and exit") -> None:
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: object, option_string: str | None = None) -> None:
        print(f"ema-rig {version()}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command registered."""
    parser = argparse.ArgumentParser(
        prog="ema-rig",
        description="Experimental modal analysis for bearing test rigs.",
    )
    parser.add_argument("--version", action=_VersionAction)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, help_text in COMMANDS.items():
        mod = importlib.import_module(f"ema_rig.commands.{name}")
        p = sub.add_parser(name, help=help_text, description=(mod.__doc__ or help_text).strip().splitlines()[0])
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run, _io=getattr(mod, "io_paths", None),
                       _whole=not getattr(mod, "OUTPUTS_ON_FAILURE", False))
    return parser


class _InertStream:
    """A text stream that escapes control and bidirectional characters on their way to the terminal.

    Newlines, tabs and carriage returns (progress bars) pass; everything else is delegated.
    """

    def __init__(self, stream: Any) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        return int(self._stream.write(inert(text, keep="\n\t\r")))

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def _sub_parser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """The parser of sub-command ``command``."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices[command]  # type: ignore[no-any-return]
    raise KeyError(command)  # pragma: no cover - build_parser always adds them


def _unrecognized(sub: argparse.ArgumentParser, extras: Sequence[str]) -> str:
    """``unrecognized arguments: --bnad (did you mean --band?)``: the sub-command's closest options."""
    options = [o for a in sub._actions for o in a.option_strings if o.startswith("--")]
    parts = []
    for e in extras:
        near = difflib.get_close_matches(e.split("=", 1)[0], options, n=1, cutoff=0.6) if e.startswith("-") else []
        parts.append(f"{e} (did you mean {near[0]}?)" if near else e)
    return "unrecognized arguments: " + " ".join(parts)


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: object = None, line: str | None = None) -> None:
    print(f"warning: {message}".replace("\n", " "), file=sys.stderr)


_SUBJECT_KEYS = ("file", "campaign", "output", "out")
"""Namespace attributes naming the file a command is about, in order of preference."""


def _subject(args: argparse.Namespace) -> str | None:
    """The file an error without a file of its own is reported against (the command's input)."""
    for key in _SUBJECT_KEYS:
        value = getattr(args, key, None)
        if value:
            return str(value)
    return None


def _error_line(head: str | None, text: str) -> str:
    return f"error: {head}: {text}".replace("\n", " ") if head else f"error: {text}".replace("\n", " ")


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``ema-rig`` with ``argv`` (default ``sys.argv[1:]``) and return the exit code.

    Every error line names a file: the one the error carries, else the command's input
    (``FILE``, ``CAMPAIGN.toml``, or the output of ``simulate`` / ``demo``). Everything printed
    has its control and bidirectional characters escaped (names read from files stay inert on the
    terminal); an output that is one of the command's inputs, a folder, under a file, or a figure
    of unknown format is refused before anything is computed; a command that fails leaves none
    of its outputs (unless its module sets ``OUTPUTS_ON_FAILURE``: inspect's report, a campaign's
    finished rows); SIGTERM, SIGHUP and Ctrl-C remove the temporary files being written.
    """
    out, err = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = _InertStream(out), _InertStream(err)
    try:
        return _main(argv)
    finally:
        sys.stdout, sys.stderr = out, err


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    words = list(sys.argv[1:] if argv is None else argv)
    try:
        if words and not words[0].startswith("-") and words[0] not in COMMANDS:
            near = difflib.get_close_matches(words[0], list(COMMANDS), n=1, cutoff=0.6)
            parser.error(f"unknown command {words[0]!r}" + (f" (did you mean {near[0]}?)" if near else "")
                         + f"; commands: {', '.join(COMMANDS)}")
        args, extras = parser.parse_known_args(words)
        if extras:  # the sub-command's own usage, with the nearest option it has
            _sub_parser(parser, args.command).error(_unrecognized(_sub_parser(parser, args.command), extras))
    except SystemExit as exc:  # argparse prints its own message
        return int(exc.code) if isinstance(exc.code, int) else EXIT_USAGE
    discarded: list[Path] = []  # outputs written, then removed because the command failed

    def error_line(head: str | None, text: str) -> str:
        if discarded:  # the command may have printed 'wrote X' for them: say they are gone
            text += f"; nothing written ({', '.join(str(p) for p in discarded)} discarded)"
        return _error_line(head, text)

    try:
        with warnings.catch_warnings():
            # user-facing warnings as one line each, no source line (restored on exit)
            warnings.showwarning = _show_warning
            if args._io is not None:
                _atomic.check_outputs(*args._io(args))
            with _atomic.removing_temporaries_on_signal():
                if not args._whole:  # the command writes what it can even when it fails
                    return int(args._run(args))
                with _atomic.all_or_nothing(discarded):  # several outputs: a failure leaves none of them
                    return int(args._run(args))
    except EmaRigError as exc:
        # str(exc) starts with the error's own file when it has one
        print(error_line(None if exc.file else _subject(args), str(exc)), file=sys.stderr)
        return EXIT_ERROR
    except BrokenPipeError:  # output piped into `head` and closed early: not an error of ours

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except (OSError, ValueError) as exc:
        # files that cannot be opened, values that cannot be used: user input, not a bug
        name = getattr(exc, "filename", None) or _subject(args)
        msg = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        print(error_line(name, msg), file=sys.stderr)
        return EXIT_ERROR
    except MemoryError as exc:  # an input far larger than the machine (numpy says how many bytes)
        detail = f" ({exc})" if str(exc) else ""
        print(error_line(_subject(args), f"not enough memory for this input{detail}"), file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
