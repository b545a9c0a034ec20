# Type stubs of the package shadefit (docs/python.md). Images: numpy float32 (H, W, C), linear
# radiance in W m^-2 sr^-1, row 0 on top; BRDF values in 1/sr; angles in degrees.
import os
from typing import Any, Literal, Mapping, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, os.PathLike[str]]
Scene = Union[PathLike, str, Mapping[str, Any]]  # a path, TOML text or a dict of tables
FloatImage = npt.NDArray[np.float32]  # (H, W, 3) or (H, W, 4), linear radiance
Mask = Union[PathLike, npt.NDArray[np.float32], npt.NDArray[np.bool_]]  # (H, W) or (H, W, 1)
Params = Union[None, Mapping[str, Union[float, Sequence[float]]], Sequence[float], "FitResult"]

class Error(ValueError):
    """Bad input or an unusable environment: the CLI's one line '<file>: <field>: <problem>'."""

class GlContextLostError(Error):
    """The GL context was lost (GPU reset); nothing rendered since can be trusted."""

class ParameterRow(TypedDict):
    name: str
    size: int  # 1 (scalar) or 3 (RGB)
    min: float
    max: float
    default: float
    log_scale: bool
    description: str

class ModelTable(TypedDict):
    name: str
    description: str
    parameters: list[ParameterRow]
    entries: list[str]  # flattened names, the order of FitResult.values

def models() -> list[ModelTable]:
    """Every shading model with its parameter table."""

def scene_toml(scene: Mapping[str, Any]) -> str:
    """The TOML text of a scene dict."""

def render(scene: Scene, model: str, params: Params = None) -> npt.NDArray[np.float32]:
    """(H, W, 4) float32: RGB linear radiance (W m^-2 sr^-1), A coverage."""

def read_image(path: PathLike) -> npt.NDArray[np.float32]:
    """(H, W, C) float32 as the CLI reads it."""

def write_exr(path: PathLike, image: npt.NDArray[np.float32]) -> None:
    """Float EXR of an (H, W[, 1|3|4]) float32 array."""

def gl_info() -> dict[str, Any]:
    """EGL platform and device, GL vendor, renderer, version."""

def metrics(reference: Union[PathLike, FloatImage], test: Union[PathLike, FloatImage],
            mask: Optional[Mask] = None, *, exposure: float = 0.0, ppd: float = 67.0,
            itp_white: float = 100.0, maps: bool = False) -> dict[str, Any]:
    """Schema shadefit.metrics/1 (docs/metrics.md); with maps=True also 'maps': (H, W) float32."""

class FitResult:
    model: str
    parameters: dict[str, float]  # entry -> value, natural units
    std_errors: dict[str, float]  # NaN when fixed or undetermined
    estimates: list[dict[str, Any]]
    values: npt.NDArray[np.float64]  # flattened, for render()
    exposure: float
    exposure_std_error: float
    exposure_free: bool
    converged: bool
    termination: str
    solver_message: str
    solver: str
    path: str
    loss: str
    iterations: int
    initial_cost: float
    final_cost: float
    rmse: float  # linear radiance, W m^-2 sr^-1
    seconds: float
    starts: list[dict[str, Any]]  # every start
    starts_reached_best: int
    covariance_status: str
    references: list[dict[str, Any]]  # name, pixels, rmse, prediction, abs_error
    json: dict[str, Any]  # the CLI's fit.json
    def __init__(self, raw: Mapping[str, Any]) -> None:
        """Made by fit() and fit_brdf() from the bindings' record, not by hand."""
    @property
    def params(self) -> dict[str, Union[float, list[float]]]: ...

Reference = Union[PathLike, Tuple[Union[PathLike, FloatImage], Scene],
                  Tuple[Union[PathLike, FloatImage], Scene, Optional[Mask]], Mapping[str, Any]]

def fit(references: Union[Reference, Sequence[Reference]], model: str, *,
        fixed: Union[None, Mapping[str, Union[float, Sequence[float]]], Sequence[str]] = None,
        loss: Literal["l2", "log", "cuberoot", "huber", "cauchy", "relative"] = "l2",
        loss_scale: float = 0.0, starts: Optional[int] = None, seed: int = 1,
        exposure: Literal["fixed", "free"] = "fixed",
        path: Literal["auto", "gbuffer", "gl"] = "auto",
        solver: Literal["auto", "bounded-lm", "ceres"] = "auto",
        max_iterations: Optional[int] = None, threads: Optional[int] = None,
        pixel_stride: int = 1, env_samples: int = 0, env_pixels: Optional[int] = None,
        env_twin_samples: Optional[int] = None, env_rounds: Optional[int] = None,
        central_differences: bool = False, render_outputs: bool = True,
        covariance: bool = True) -> FitResult:
    """Fits model jointly to one material's references."""

def fit_brdf(path: PathLike, model: str, *,
             fixed: Union[None, Mapping[str, Union[float, Sequence[float]]], Sequence[str]] = None,
             cells: Tuple[int, int, int] = (90, 45, 45), max_theta: float = 80.0,
             starts: Optional[int] = None, seed: int = 1, solver: str = "auto",
             max_iterations: Optional[int] = None, threads: Optional[int] = None) -> FitResult:
    """Fits model to a measured BRDF in BRDF space (Ngan et al. 2005)."""

class MeasuredBrdf:
    @property
    def format(self) -> str:
        """'merl-binary' or 'neural-brdf'."""
    @property
    def files(self) -> list[str]: ...
    def eval(self, wi: npt.ArrayLike, wo: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """f(wi, wo) in 1/sr, (..., 3); directions (..., 3) in the local frame, normal +z."""

def load_brdf(path: PathLike) -> MeasuredBrdf:
    """MERL .binary or Neural-BRDF .h5."""

def probe_names() -> list[str]: ...

def probe(name: str, references: Union[PathLike, Sequence[PathLike]] = (),
          models: Union[str, Mapping[str, Any], FitResult,
                        Sequence[Union[str, Mapping[str, Any], FitResult]]] = (), *,
          truth_from_sidecar: bool = False, brdf: Optional[PathLike] = None) -> dict[str, Any]:
    """Schema shadefit.probe/3."""

def run_study(path: PathLike, out: PathLike = "out", *, quick: bool = False, jobs: int = 0,
              force: bool = False, report: bool = True, quiet: bool = True) -> Optional[str]:
    """Returns the study folder."""

def load_results(study: PathLike,
                 table: Literal["results", "timings"] = "results") -> list[dict[str, Any]]:
    """Rows as dicts (pandas.DataFrame takes them)."""
