"""``python -m mpeg4fba`` runs the ``mpeg4fba`` command."""
from .cli import main

if __name__ == "__main__":
    main()
