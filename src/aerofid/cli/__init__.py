"""Command-line interface: a thin layer over the Python API.

Exit status: 0 when the job succeeded (every mark was found), 1 when it ran but did not (a mark not found, an
ambiguous orientation), 2 on bad input (one line ``error: ...`` on stderr, no traceback, nothing written).
``aerofid`` (the console script), ``python -m aerofid`` and ``python -m aerofid.cli`` are the same command.
"""

from __future__ import annotations

import sys

import click

from aerofid.errors import AerofidInputError


class _Group(click.Group):
    """Click group whose errors are one line ``error: ...`` and exit status 2."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        try:
            rv = super().main(args=args, prog_name=prog_name, complete_var=complete_var,
                              standalone_mode=False, **extra)
        except click.exceptions.Exit as e:  # --help, --version
            sys.exit(e.exit_code)
        except click.exceptions.Abort:
            click.echo("error: aborted", err=True)
            sys.exit(2)
        except click.ClickException as e:
            click.echo(f"error: {e.format_message()} (see 'aerofid --help')", err=True)
            sys.exit(2)
        except AerofidInputError as e:
            click.echo(f"error: {e}", err=True)
            sys.exit(2)
        sys.exit(rv if isinstance(rv, int) else 0)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="aerofid")
def main() -> None:
    """aerofid: fiducial marks and ground panels in scanned aerial photographs, to a fraction of a pixel."""


def _register() -> None:
    from aerofid.cli import demo_cmd, locate_cmd, orient_cmd

    main.add_command(locate_cmd.locate)
    main.add_command(demo_cmd.demo)
    main.add_command(orient_cmd.orient)


_register()
