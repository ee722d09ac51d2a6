"""Exceptions with messages that say what failed, where, and what was expected."""


class InfeasibleDesign(RuntimeError):
    """An LMI design has no (certified) solution.

    Attributes
    ----------
    lmi : str | None
        Name of the violated LMI (e.g. ``"Xi[3]"``) or ``None`` when the solver declared the
        whole problem infeasible.
    violation : float | None
        By how much it is violated: the largest eigenvalue of a constraint that must be
        negative definite (positive means violated), or the most negative entry of an
        element-wise constraint.
    """

    def __init__(self, message, lmi=None, violation=None, status=None):
        super().__init__(message)
        self.lmi = lmi
        self.violation = violation
        self.status = status


class CertificationError(InfeasibleDesign):
    """The solver returned a solution but the independent eigenvalue check rejects it."""


class LogFormatError(ValueError):
    """A drive log does not follow the schema: names the column/row and what was expected."""


class PremiseOutOfBounds(ValueError):
    """A premise variable left the sector bounds on which a TS model is exact."""

    def __init__(self, message, premise=None, index=None, value=None, bounds=None):
        super().__init__(message)
        self.premise = premise
        self.index = index
        self.value = value
        self.bounds = bounds


class ObserverArgumentError(ValueError):
    """An argument of a public design or run function is wrong (sign, shape, finiteness,
    time step): the message names the argument and what was expected."""


class RegistryError(ValueError):
    """An estimator registration or look-up is wrong (unknown name, duplicate name, a
    plug-in that does not follow the estimator protocol): the message names it."""


class PluginError(RuntimeError):
    """Code of a plug-in (an estimator or truth plant registered from outside the library)
    raised, or a plug-in module failed to import: a problem of that code, never of the
    user's input. The message names the plug-in and the file:line where it raised;
    ``__cause__`` is the original exception (its traceback: the command line's ``--debug``).

    Attributes
    ----------
    plugin : str
        The estimator (or module) name.
    where : str
        ``"path/to/file.py:LINE (in FUNCTION)"`` of the plug-in's innermost frame, or ``""``.
    """

    def __init__(self, message, plugin="", where=""):
        super().__init__(message)
        self.plugin = plugin
        self.where = where
