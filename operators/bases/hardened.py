# SPDX-License-Identifier: GPL-3.0-or-later
"""One hardened ``execute`` for every operator: bad input becomes a clear report, never a traceback
in the user's face, and the scene is left as it was (the operator raised before changing it, and
Blender's undo step is not pushed for a cancelled operator). Input the engine took after a correction
(``InputWarning``: a preset's value clamped into its range) is reported as a warning, once per message."""
from __future__ import annotations

import traceback
import warnings

from ...faces_hands_addon.core.errors import InputWarning, UserError


class HardenedOperator:
    """Mixin: subclasses implement ``run(context)`` instead of ``execute``."""

    def run(self, context):  # pragma: no cover - overridden
        raise NotImplementedError

    def execute(self, context):
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", InputWarning)
                result = self.run(context)
            for message in dict.fromkeys(str(w.message) for w in caught if issubclass(w.category, InputWarning)):
                self.report({"WARNING"}, message)
            for other in caught:
                if not issubclass(other.category, InputWarning):
                    warnings.warn_explicit(other.message, other.category, other.filename, other.lineno)
            return result
        except UserError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        except Exception as error:  # a bug: report it in one line, keep the details in the console
            traceback.print_exc()
            self.report({"ERROR"}, f"Internal error ({type(error).__name__}: {error}); see the console")
            return {"CANCELLED"}
