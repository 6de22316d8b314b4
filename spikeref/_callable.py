"""Modules that share their name with the public function they define stay callable.

``spikeref.accumulate`` is both a module and the public function ``sr.accumulate`` (the
same for ``align`` and ``noise_check``).  Python's import system binds a submodule to its
package's attribute when the submodule is first imported, so after
``import spikeref.accumulate`` (done by any other module) ``spikeref.accumulate`` is the
module, not the function.  Making such a module callable — calling it calls its function —
keeps ``sr.accumulate(spikes, 10)`` working in every import order, while
``import spikeref.accumulate as m`` still gives the module with all its names.
"""

from __future__ import annotations

import sys
import types

__all__ = ["make_module_callable"]


class _CallableModule(types.ModuleType):
    def __call__(self, *args, **kwargs):
        return getattr(self, self.__dict__["_public_function"])(*args, **kwargs)


def make_module_callable(module_name: str, function_name: str) -> None:
    """Let ``module(...)`` call ``module.function_name(...)``."""
    module = sys.modules[module_name]
    module._public_function = function_name
    module.__class__ = _CallableModule
