# SPDX-License-Identifier: MIT
import sys

from vdtools.adapt import main

sys.exit(main())
