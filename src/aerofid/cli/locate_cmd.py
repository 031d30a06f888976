"""`aerofid locate` (placeholder until its issue lands)."""

import click


@click.command()
def locate() -> int:
    """Not implemented yet."""
    raise click.UsageError("'locate' is not implemented yet")
