"""From a user's :class:`~symbolic.spec.System` to code.

:mod:`symbolic.codegen.definition` is the language-neutral part: it differentiates every
family with the Lie engine and returns a :class:`~symbolic.codegen.definition.SystemDefinition`
(kernels, degrees, row names, parameter shapes, defaults). A backend under
``backends/<language>/`` prints that definition; ``backends/rust`` is the only one today.
"""
