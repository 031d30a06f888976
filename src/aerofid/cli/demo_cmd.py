"""`aerofid demo` (placeholder until its issue lands)."""

import click


@click.command()
def demo() -> int:
    """Not implemented yet."""
    raise click.UsageError("'demo' is not implemented yet")
