"""``python -m ballchain.cli``."""

from . import main

main()
