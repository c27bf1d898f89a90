"""Joint kinds, as the model stores them (``Model.kind``): a leaf module that the model,
the reference algorithms and the compiled core all import, so none imports another."""
REVOLUTE, PRISMATIC = 0, 1
