"""Policies as data that can travel to another machine: the trained policies of a study
and the model-based controllers, loaded where an evaluation cell runs (this process or a
Ray worker; :mod:`chaincart_env.tools.compare.cell_runner`).

A :class:`PolicySource` holds an SB3 model's file contents, an RLlib RLModule's folder
packed into a tar archive, a model-based controller's name and the scene
configuration it is designed on, or the scene and name of a shipped agent (which
every installation of the package has).
:meth:`PolicySource.load` builds the policy; each process keeps the policies it loaded,
so a worker that evaluates one policy on many scene variants loads it once.
"""

from __future__ import annotations

import hashlib
import io
import json
import tarfile
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.run_files import (
    BEST_MODEL_FILE,
    CHECKPOINT_DIR,
    CONFIG_FILE,
    MODEL_FILE,
    RUN_FILE,
    SavedRun,
    read_json_object,
)  # fmt: skip

__all__ = ["PolicySource", "load_run"]

#: Extraction that refuses links and paths out of the folder, where Python has it.
_SAFE_EXTRACTION: dict[str, Any] = {"filter": "data"} if hasattr(tarfile, "data_filter") else {}
#: Policies loaded by this process, by source key.
_LOADED: dict[str, Any] = {}


@dataclass(frozen=True)
class PolicySource:
    """What :meth:`load` needs to build one policy: ``kind`` is ``"sb3"`` (``payload``:
    the model's zip file, ``algo``: its algorithm, ``statistics``: the contents of its
    observation normalisation file, if it has one), ``"rllib"`` (the RLModule folder as
    a tar archive) or ``"model"`` (a model-based controller: ``payload`` holds its name
    and the scene's ``ChainCartConfig`` keywords; ``oracle``: the per-episode design on
    the true parameters) or ``"pretrained"`` (a shipped agent: ``payload`` holds its
    scene and name)."""

    kind: str
    payload: Any
    algo: str = ""
    oracle: bool = False
    statistics: Optional[bytes] = None

    @classmethod
    def sb3(cls, path: Path, algo: str) -> "PolicySource":
        """The SB3 model saved at ``path`` (trained with ``algo``), with the normalisation
        statistics saved beside it if there are any."""
        from chaincart_env.tools.compare.normalization import normalization_file

        statistics = normalization_file(path)
        return cls("sb3", Path(path).read_bytes(), algo=algo,
                   statistics=statistics.read_bytes() if statistics.is_file() else None)

    @classmethod
    def rllib(cls, module: Path) -> "PolicySource":
        """The RLModule saved in the folder ``module``."""
        buffer = io.BytesIO()
        with tarfile.open(fileobj=buffer, mode="w") as archive:
            archive.add(str(module), arcname=".")
        return cls("rllib", buffer.getvalue())

    @classmethod
    def model_based(cls, controller: str, config: ChainCartConfig, oracle: bool = False) -> "PolicySource":
        """Model-based controller ``controller`` (a name of
        :data:`~chaincart_env.tools.controllers.MODEL_BASED`) designed on ``config``'s
        nominal model (``oracle``: on each episode's true parameters)."""
        return cls("model", {"controller": controller, "config": config.to_dict()}, oracle=oracle)

    @classmethod
    def lqr(cls, config: ChainCartConfig, oracle: bool = False) -> "PolicySource":
        """The LQR baseline of ``config`` (``oracle``: designed on each episode's true parameters)."""
        return cls.model_based("lqr", config, oracle)

    @classmethod
    def pretrained(cls, scene: str, name: str) -> "PolicySource":
        """The shipped agent ``pretrained:<scene>/<name>``."""
        return cls("pretrained", {"scene": scene, "name": name})

    @classmethod
    def of_run(cls, directory: Path) -> "PolicySource":
        """The final policy of a trained run folder (``seed-<s>/``) of ``compare``."""
        from chaincart_env.tools.compare.rllib_training import MODULE_PATH

        directory = Path(directory)
        info = read_json_object(directory / RUN_FILE)
        if info.get("trainer") == "rllib":
            module = directory.joinpath(CHECKPOINT_DIR, *MODULE_PATH)
            if not module.is_dir():
                raise InvalidInputError(f"{module} does not exist: expected the RLModule inside an RLlib checkpoint")
            return cls.rllib(module)
        if not (directory / MODEL_FILE).is_file():
            raise InvalidInputError(f"{directory / MODEL_FILE} does not exist: expected an SB3 model saved by compare")
        return cls.sb3(directory / MODEL_FILE, str(info.get("algo")))

    @classmethod
    def best_of_run(cls, directory: Path) -> Optional["PolicySource"]:
        """The best-by-evaluation model an SB3 run folder kept, if any."""
        best = Path(directory) / BEST_MODEL_FILE
        if not best.is_file():
            return None
        return cls.sb3(best, str(read_json_object(Path(directory) / RUN_FILE).get("algo")))

    @property
    def key(self) -> str:
        """Equal for sources that load the same policy."""
        data = self.payload if isinstance(self.payload, bytes) else json.dumps(self.payload, sort_keys=True).encode()
        statistics = "" if self.statistics is None else ":" + hashlib.sha256(self.statistics).hexdigest()
        return f"{self.kind}:{self.algo}:{self.oracle}:{hashlib.sha256(data).hexdigest()}{statistics}"

    def load(self) -> Any:
        """The policy (``predict`` like an SB3 model), loaded once per process."""
        key = self.key
        if key not in _LOADED:
            _LOADED[key] = self._build()
        return _LOADED[key]

    def _build(self) -> Any:
        if self.kind == "sb3":
            from chaincart_env.tools.compare.algorithms import algorithm_class
            from chaincart_env.tools.compare.normalization import read_statistics, with_statistics

            model = algorithm_class(self.algo).load(io.BytesIO(self.payload), device="cpu")
            return with_statistics(model, None if self.statistics is None else read_statistics(self.statistics))
        if self.kind == "rllib":
            from chaincart_env.tools.compare.rllib_training import RLlibPolicy

            with tempfile.TemporaryDirectory() as folder:
                with tarfile.open(fileobj=io.BytesIO(self.payload)) as archive:
                    archive.extractall(folder, **_SAFE_EXTRACTION)
                return RLlibPolicy.from_module(Path(folder))
        if self.kind == "model":
            from chaincart_env.tools.controllers import build_model_based

            config = ChainCartConfig(**self.payload["config"])
            return build_model_based(self.payload["controller"], config, oracle=self.oracle)
        if self.kind == "pretrained":
            from chaincart_env.pretrained_agents import pretrained

            return pretrained(self.payload["scene"], self.payload["name"])
        raise InvalidInputError(f"policy source kind {self.kind!r}: expected 'sb3', 'rllib', 'model' or 'pretrained'")


def load_run(path: Path) -> SavedRun:
    """A run directory written by ``compare``, or the ``model.zip`` (SB3) or
    ``rllib_checkpoint`` (RLlib) inside one. An SB3 model saved with normalisation
    statistics loads as a :class:`~chaincart_env.tools.compare.normalization.NormalizedPolicy`."""
    path = Path(path)
    if path.is_dir() and path.name == CHECKPOINT_DIR:
        path = path.parent
    if path.is_dir() and (path / CHECKPOINT_DIR).is_dir():
        from chaincart_env.tools.compare.rllib_training import RLlibPolicy

        directory = path
        info = read_json_object(directory / RUN_FILE)
        model: Any = RLlibPolicy.load(directory / CHECKPOINT_DIR)
    else:
        if path.is_dir():
            directory, model_path = path, path / MODEL_FILE
        elif path.suffix == ".zip":
            directory, model_path = path.parent, path
        else:
            raise InvalidInputError(
                f"model {str(path)!r}: expected a run directory, a .zip model file or an {CHECKPOINT_DIR} that exists"
            )
        if not model_path.is_file():
            raise InvalidInputError(f"{model_path} does not exist: expected an SB3 model saved by compare")
        info = read_json_object(directory / RUN_FILE)
        from chaincart_env.tools.compare.algorithms import algorithm_class
        from chaincart_env.tools.compare.normalization import load_statistics, with_statistics

        model = with_statistics(algorithm_class(str(info.get("algo"))).load(model_path, device="cpu"),
                                load_statistics(model_path))
    config = ChainCartConfig(**read_json_object(directory / CONFIG_FILE))
    return SavedRun(model=model, config=config, info=info, directory=directory)
