"""Forward-dynamics simulation of a serial chain.

``sd.simulate`` is ``driver.simulate``. The modules, leaves first:

- ``methods``: method names by family, defaults, ``SimulationError`` and its advice;
- ``steps``: the compiled semi-implicit Euler update, shared with the compiled loop;
- ``equations``: the equations of motion with the friction modes, the state checks;
- ``explicit`` (semi-implicit Euler, RK4), ``symplectic`` (symplectic Euler in momentum
  form), ``implicit`` (implicit midpoint, Newton): one fixed step of each method;
- ``jacobians``: the analytical (or finite-difference) Jacobians of the implicit methods;
- ``stops``: hard stops at the joint limits; ``servo``: the joint servo (implicit PD);
- ``compiled_euler``: the compiled whole-run semi-implicit Euler loop, ``compiled_run``:
  ``simulate``'s run on it; ``fixed_step``: ``FixedStepIntegrator`` and the fixed-step run
  loops; ``adaptive``: the run loop over scipy's solvers;
- ``result``: ``SimulationResult``, ``SolverStats``; ``progress``: the progress bar;
- ``driver``: ``simulate``.

This file imports nothing, so that a module of the compiled core can import
``serial_dynamics.sim.steps`` without importing the simulator.
"""
