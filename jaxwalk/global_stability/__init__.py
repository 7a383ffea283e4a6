"""Global stability measures beyond one step-down (issue 15).

* :mod:`~jaxwalk.global_stability.sensitivity_norm`: the gait sensitivity norm
  (Hobbelen & Wisse 2007), the H2 norm of the linearised step-to-step response
  of gait indicators to floor-height disturbances;
* :mod:`~jaxwalk.global_stability.walks`: walks over given or random terrain,
  batched (Monte Carlo steps-to-fall);
* :mod:`~jaxwalk.global_stability.mfpt`: the mean first-passage time on random
  terrain from the discretised step-to-step Markov chain (Byl & Tedrake 2009).
"""
