import sys
from pathlib import Path

# The protocol tests share small helpers (protocol_testing.py) next to them.
sys.path.insert(0, str(Path(__file__).resolve().parent))
