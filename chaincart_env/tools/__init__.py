"""The command-line tools of ``python -m chaincart_env``, apart from the library.

``import chaincart_env`` loads the envs, the model and the policies; nothing here is
imported until a command (or a test) asks for it. Tools import the library, never
the reverse.

* :mod:`~chaincart_env.tools.bench`: the benchmark suite (``bench``).
* :mod:`~chaincart_env.tools.compare`: the main job, a learned policy against the
  LQR baseline (``compare``, ``evaluate``, ``chaincart-compare``).
* :mod:`~chaincart_env.tools.figures`, :mod:`~chaincart_env.tools.plots`: the paper's
  figures (``figures``).
* :mod:`~chaincart_env.tools.roa_cli`: the LQR baseline's region of attraction as a table,
  CSV and PNG (``roa``; the curve itself is the library's :mod:`chaincart_env.roa`).
* :mod:`~chaincart_env.tools.animate`: GIF/MP4 of an episode (``animate``).
* :mod:`~chaincart_env.tools.demo`, :mod:`~chaincart_env.tools.soak`: one episode
  (``demo``) and a long memory run (``soak``).
* :mod:`~chaincart_env.tools.config_docs`: the generated parts of the docs (``docs``).
* :mod:`~chaincart_env.tools.analysis_cli`: the ``figures`` and ``roa`` commands.
"""
