"""Alembic environment and revisions of the CausalSplat store schema.

Run them with ``causalsplat db upgrade --db URL`` (or ``alembic -x db=URL upgrade head``
from the repository root).
"""

from pathlib import Path

#: The directory Alembic uses as its script location.
SCRIPT_LOCATION = Path(__file__).resolve().parent
