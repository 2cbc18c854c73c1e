"""A twin of your own machine from its servo logs (issue 64).

* :mod:`~agents.twin.generate`: test logs of a preset's machine with hidden, perturbed
  parameters (what no test tunes to);
* :mod:`~agents.twin.replay`: a log's commands replayed through the closed loop of a plant,
  many candidate plants at once.
"""
