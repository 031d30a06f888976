"""``python -m aerofid``: the ``aerofid`` command (the same as the console script)."""

from aerofid.cli import main

if __name__ == "__main__":
    main(prog_name="aerofid")
