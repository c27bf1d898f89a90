"""Dynamics algorithms: pure functions of (model, state), one module each.

Every function accepts a single state, shape ``(n,)``, or a batch ``(N, n)``, and
returns results with the matching leading shape. These NumPy implementations are
the readable reference; ``kernels.py`` holds compiled equivalents that the
``Robot`` facade uses for speed and that the tests compare against these.
"""
