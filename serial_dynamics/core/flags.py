"""Flags of the compiled entry points (bit fields of their ``flags`` argument)."""
QD = 1          # use qd (else qd = 0)
QDD = 2         # use qdd (else qdd = 0)
WRENCH = 4      # a tip wrench is given (w[:6]; else not read)
ABA = 8         # forward dynamics by the articulated-body algorithm (else Cholesky of M)
DAMPING = 16    # forward dynamics of (M + diag(damping)) qdd = tau - b (implicit damping)
BASE = 32       # the base moves: w also holds its motion (layout.W_OMEGA ..; w has W_ALL entries)
