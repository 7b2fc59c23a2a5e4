import sys

from vrelab.cli import main

sys.exit(main())
