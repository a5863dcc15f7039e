# SPDX-License-Identifier: GPL-3.0-or-later
"""One hardened ``execute`` for every operator: bad input becomes a clear report, never a traceback
in the user's face, and the scene is left as it was (the operator raised before changing it, and
Blender's undo step is not pushed for a cancelled operator)."""
from __future__ import annotations

import traceback

from ...faces_hands_addon.core.errors import UserError


class HardenedOperator:
    """Mixin: subclasses implement ``run(context)`` instead of ``execute``."""

    def run(self, context):  # pragma: no cover - overridden
        raise NotImplementedError

    def execute(self, context):
        try:
            return self.run(context)
        except UserError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        except Exception as error:  # a bug: report it in one line, keep the details in the console
            traceback.print_exc()
            self.report({"ERROR"}, f"Internal error ({type(error).__name__}: {error}); see the console")
            return {"CANCELLED"}
