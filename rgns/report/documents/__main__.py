"""``python -m rgns.report.documents``: rewrite (or ``--check``) every rendered passage."""

import sys

from rgns.report.documents import main

sys.exit(main())
