"""The glue: where the library meets the simulator, files, figures and people.

The library (every other module of :mod:`neuroslam`) needs numpy, scipy, OpenCV and numba only; the modules here may
import the MuJoCo testbed (:mod:`sim`), gymnasium, rerun, Ray, matplotlib and tqdm:

- :mod:`~neuroslam.lab.cli`: the ``neuroslam`` command (drive, run, record, sweep, nav, ...);
- :mod:`~neuroslam.lab.recording`: a rerun recording of a run (``--record``);
- :mod:`~neuroslam.lab.plots`: the report figure;
- :mod:`~neuroslam.lab.wrappers`: a gymnasium wrapper that attaches the SLAM estimate to an environment;
- :mod:`~neuroslam.lab.nav`: navigation episodes with a pose from ground truth, wheels or the SLAM;
- :mod:`~neuroslam.lab.sweep`: drives as Ray tasks over worlds and settings.

``pyproject.toml`` declares the layering for import-linter (``lint-imports``, run by ``.ci/run``).
"""
