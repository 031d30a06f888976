"""``python -m aerofid.cli``: the ``aerofid`` command (as ``python -m aerofid``)."""

from aerofid.cli import main

if __name__ == "__main__":
    main(prog_name="aerofid")
