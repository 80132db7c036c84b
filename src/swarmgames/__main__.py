"""``python -m swarmgames``: the same as the ``swarmgames`` command."""

from swarmgames.cli import main

if __name__ == "__main__":
    main(quick_exit=True)
