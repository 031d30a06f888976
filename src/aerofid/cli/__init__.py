"""Command-line interface: a thin layer over the Python API.

Exit status: 0 when the job succeeded (every mark was found), 1 when it ran but did not (a mark not found, an
ambiguous orientation), 2 on bad input or a failed output, standard output included (one line ``error: ...``
on stderr, no traceback, nothing written), 3 on an internal error (a bug: one line asking for a report).
``aerofid`` (the console script), ``python -m aerofid`` and ``python -m aerofid.cli`` are the same command.
"""

from __future__ import annotations

import importlib
import sys

import click

from aerofid.cli.output import (
    EXIT_BAD_INPUT,
    echo_error,
    error_line,
    flush_stdout,
    is_stream_error,
    quiet_libraries,
    stdout_error,
)

COMMANDS = {
    "locate": "aerofid.cli.locate_cmd:locate",
    "demo": "aerofid.cli.demo_cmd:demo",
    "orient": "aerofid.cli.orient_cmd:orient",
    "learn": "aerofid.cli.frame_cmd:learn",
    "batch": "aerofid.cli.batch_cmd:batch",
    "resample": "aerofid.cli.resample_cmd:resample",
}
"""Each command and where it lives (``module:name``), imported only when it is run or listed by ``--help``: a call
of one command pays for nothing else's imports (``aerofid locate`` does not load the batch driver)."""


class _Group(click.Group):
    """Click group whose every ending is one line on stderr at most and a documented exit status
    (:mod:`aerofid.cli.output`), its commands imported on first use (:data:`COMMANDS`)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        where = COMMANDS.get(cmd_name)
        if where is None:
            return None
        module, name = where.split(":")
        command: click.Command = getattr(importlib.import_module(module), name)
        return command

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        with quiet_libraries():
            status = self._run(args, prog_name, complete_var, **extra)
        sys.exit(status)

    def _run(self, args, prog_name, complete_var, **extra) -> int:
        try:
            rv = super().main(args=args, prog_name=prog_name, complete_var=complete_var,
                              standalone_mode=False, **extra)
            flush_stdout()
        except click.exceptions.Exit as e:  # --help, --version
            return e.exit_code
        except click.exceptions.Abort:  # Ctrl-C
            echo_error("error: interrupted: what was not finished is not written; run the command again (a batch "
                       "resumes, its complete frames kept)")
            return EXIT_BAD_INPUT
        except click.ClickException as e:
            echo_error(f"error: {e.format_message()} (see 'aerofid --help')")
            return EXIT_BAD_INPUT
        except Exception as e:  # every other ending: one line and its status (aerofid.cli.output.error_line)
            line, status = error_line(e)
            echo_error(line)
            return status
        return rv if isinstance(rv, int) else 0

    def invoke(self, ctx: click.Context):
        """Run the command; a failed write to standard output is an input error here, before click would turn a
        closed pipe into a silent exit status 1."""
        try:
            return super().invoke(ctx)
        except OSError as e:
            if is_stream_error(e):
                raise stdout_error(e) from None
            raise


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="aerofid")
def main() -> None:
    """aerofid: fiducial marks and ground panels in scanned aerial photographs, to a fraction of a pixel."""
