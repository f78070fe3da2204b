import sys

from porosense.cli import main

sys.exit(main())
