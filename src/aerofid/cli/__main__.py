"""``python -m aerofid.cli``."""

from aerofid.cli import main

if __name__ == "__main__":
    main()
