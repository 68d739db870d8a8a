"""The studies: what the CLI's study commands and the harness compute from the core, each a module
returning dataclasses (the reports write them: ``crankfmu.output`` the files, ``crankfmu.plots`` the
figures):

  kinematics    positions, velocities, accelerations over a cycle and at an angle (seed 002, 004)
  equilibrium   the equilibrium moment and joint reactions at constant speed (seed 001)
  flywheel      the steady cycle, flywheel sizing and the eq. 3 step study (seed 003)
  schemes       the papers' crank-angle schemes against the reference (seed 000)
  batch         steady cycles of many designs in one call of the C kernel
  sweep         a grid of designs, in parallel chunks, resumable
  paper_models  the papers' own approximate formulas, for comparison

None of this ships in an FMU (fmi.python.build.RUNTIME).
"""
