"""The course layer over the notebooks (notebook 00, "start here").

- :mod:`.path`: the learning path: the order of the notebooks, what each needs before it, its
  learning objectives and its reading time (computed from the notebook files), and a figure of
  the path;
- :mod:`.families`: the observer families side by side (what each measures and needs, its
  guarantee and knobs), run on one common manoeuvre and on the real log through the estimator
  registry, with their cost per step;
- :mod:`.exercises`: the checkers of notebook 00's exercises (notation, registry runs, which
  estimator fits a sensor set).
"""
