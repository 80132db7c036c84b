"""``python -m swarmgames``: the same as the ``swarmgames`` command."""

from swarmgames.cli import script

if __name__ == "__main__":
    script()
