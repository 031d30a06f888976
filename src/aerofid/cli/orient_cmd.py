"""`aerofid orient` (placeholder until its issue lands)."""

import click


@click.command()
def orient() -> int:
    """Not implemented yet."""
    raise click.UsageError("'orient' is not implemented yet")
