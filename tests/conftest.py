"""Suite-wide settings.

Under CI (the ``CI`` environment variable set, as ``.ci/run`` runs), hypothesis draws the same
examples on every run (``derandomize``), so a run on main is reproducible; a developer's run
keeps exploring new examples.
"""

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
