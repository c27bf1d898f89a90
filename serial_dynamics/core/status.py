"""What a compiled entry point returns: a status code, named once.

A leaf module (no import of the algorithms), so that every kernel can return these names
(numba reads module-level integers as constants when it compiles) and the facade can test
them; ``core.dispatch`` re-exports them.

    OK             0   the result is written
    NOT_FINITE     1   a NaN or Inf in an input (the caller then raises the reference's
                       ValueError naming it)
    BAD_LENGTH     2   an argument of the wrong length or shape
    OTHER_TYPES    3   arguments of other types than the entry point's one signature (a
                       single-state entry point; ``dispatch``'s hook returns it)
    NOT_CONVERGED  4   an iteration did not converge (the symplectic Euler step)

An entry point that counts something (``energy.symplectic_euler``: the fixed-point
iterations, >= 1) returns the count, or minus a status code.
"""
from numba import njit

OK, NOT_FINITE, BAD_LENGTH, OTHER_TYPES, NOT_CONVERGED = 0, 1, 2, 3, 4


@njit(cache=True, inline="always")
def status(chk):
    """An entry point's status from its check sum of the inputs (``spatial.finite``):
    OK, or NOT_FINITE if the sum is NaN."""
    return OK if chk == 0.0 else NOT_FINITE
