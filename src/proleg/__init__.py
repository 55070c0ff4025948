"""proleg: virtual prototyping of legged robots (multibody dynamics in JAX, float64)."""

import jax as _jax

# float64 for the whole process: required (docs/global-settings.md lists what import proleg sets)
_jax.config.update("jax_enable_x64", True)


def _enable_compilation_cache():
    """Persistent XLA compilation cache in the user's cache folder, so a model compiled once is
    not recompiled by the next process (set PROLEG_CACHE_DIR to move it, or to "" to disable;
    proleg.compile_cache keeps the traced functions in its export/ folder, and JAX's executables
    go through the same crash-safe store, in its xla/ folder: proleg.cache_store).
    PROLEG_JAX_CACHE=0 leaves JAX's configuration alone (docs/global-settings.md)."""
    import os

    from .cache_store import install_jax_cache
    from .compile_cache import cache_dir

    path = cache_dir()
    if path and os.environ.get("PROLEG_JAX_CACHE", "1") != "0":
        install_jax_cache(path)


_enable_compilation_cache()


def _jaxlib_has_option(name: str) -> bool:
    """Whether this jaxlib's XLA knows the option ``name`` (XLA aborts the process on an unknown
    flag in XLA_FLAGS, so the name is looked up in jaxlib's libraries first)."""
    import glob
    import mmap
    import os

    try:
        import jaxlib

        libs = sorted(glob.glob(os.path.join(os.path.dirname(jaxlib.__file__), "*.so")), key=os.path.getsize, reverse=True)
        for lib in libs:
            with open(lib, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as m:
                if m.find(name.encode()) >= 0:
                    return True
    except (OSError, ValueError, ImportError):
        return False
    return False


# XLA-CPU options proleg sets in XLA_FLAGS (see _xla_cpu_defaults), as name: value.
XLA_CPU_DEFAULTS = {
    # The concurrency-optimized scheduler lets independent kernels run on the thread pool; a
    # simulation step is a few hundred microsecond-sized kernels, and the thread hand-offs cost
    # more than they save: off, a step takes about two thirds of the time with half the CPU time
    # (docs/performance.md, "What made the difference").
    "xla_cpu_enable_concurrency_optimized_scheduler": "false",
    # YNNPACK fusions run the element code's small batched products (one batch entry per
    # colour of the Newton matrix's JVPs, or per vmap lane) entry by entry: on a model with many
    # colours they were half of a step, and a third of a vmap batch's lane-step; without them no
    # model measured got slower (docs/performance.md).
    "xla_cpu_experimental_ynn_fusion_type": "",
    # Not set: --xla_cpu_copy_insertion_use_region_analysis=true copies fewer of a while loop's
    # carried values (Go1's step 645 → 622 kernels) but computes wrong answers: the four-bar's
    # Radau5 run ended 2.5e-3 rad from its closed form (tests/test_core_fourbar.py; jaxlib 0.10.2).
}

# Environment variables proleg sets for XLA-CPU (see _xla_cpu_defaults), as name: value.
XLA_CPU_ENV_DEFAULTS = {
    # The size of XLA-CPU's intra-op thread pool (XLA reads PJRT_NPROC, then NPROC, then counts
    # the cores). Its executor hands a step's independent microsecond-sized kernels to the pool's
    # threads, and on a 2-core VM each hand-off cost more than the kernel: with one pool thread a
    # standing Go1 ran 1 s in 0.13 s where two threads took 0.15–0.19 s and four 0.15–0.30 s
    # (the same steps; docs/performance.md). Concurrent executions still run in parallel (each on
    # its caller's thread: sweep's concurrent batches), and a vmap batch of 256 and a sweep ran
    # at the same speed (bench/vmap_batch.py). A single very large batch of your own on a
    # many-core CPU may want the pool back: set PJRT_NPROC to the number of cores.
    "PJRT_NPROC": "1",
}


def _xla_cpu_defaults():
    """Set XLA_CPU_DEFAULTS in XLA_FLAGS and XLA_CPU_ENV_DEFAULTS in the environment before JAX
    starts its backend.

    Each option is left alone when XLA_FLAGS already names it (set it yourself to keep XLA's
    default), a flag when this jaxlib does not have it, and all of them when PROLEG_XLA_DEFAULTS=0;
    PJRT_NPROC also when it or NPROC is set (the older name XLA reads for the same number). They are
    read when JAX's backend starts: importing proleg after running JAX code has no effect.
    """
    import os

    if os.environ.get("PROLEG_XLA_DEFAULTS", "1") == "0":
        return
    for name, value in XLA_CPU_DEFAULTS.items():
        flags = os.environ.get("XLA_FLAGS", "")
        if name not in flags and _jaxlib_has_option(name):
            os.environ["XLA_FLAGS"] = f"{flags} --{name}={value}".strip()
    for name, value in XLA_CPU_ENV_DEFAULTS.items():  # (a variable XLA does not read is harmless: no lookup)
        if name not in os.environ and not (name == "PJRT_NPROC" and "NPROC" in os.environ):
            os.environ[name] = value


_xla_cpu_defaults()


def _preload_lapack():
    from ._lapack_table import preload

    preload()


_preload_lapack()

__version__ = "0.1.0"

from . import units as units
from .errors import ConvergenceError as ConvergenceError
from .errors import DataError as DataError
from .errors import Interrupted as Interrupted
from .errors import ModelError as ModelError
from .errors import ProlegWarning as ProlegWarning
from .errors import SolverError as SolverError
from .model.forces import Bushing as Bushing
from .model.forces import Force as Force
from .model.forces import RotationalSpringDamper as RotationalSpringDamper
from .model.forces import SpringDamper as SpringDamper
from .model.forces import Torque as Torque
from .model.joints import Cylindrical as Cylindrical
from .model.joints import Fixed as Fixed
from .model.joints import Planar as Planar
from .model.joints import Prismatic as Prismatic
from .model.joints import Revolute as Revolute
from .model.joints import Screw as Screw
from .model.joints import Spherical as Spherical
from .model.joints import Translational as Translational
from .model.joints import Universal as Universal
from .model.model import Model as Model
from .model.parts import Marker as Marker
from .model.parts import Part as Part
from .assembly.system import System as System
from .assembly.assemble import assemble as assemble
from .solvers.galpha import HHT as HHT
from .solvers.auto import Auto as Auto
from .solvers.base import AbstractIntegrator as AbstractIntegrator
from .solvers.galpha import AbstractAlphaIntegrator as AbstractAlphaIntegrator
from .solvers.galpha import GeneralizedAlpha as GeneralizedAlpha
from .solvers.ode import Dopri5 as Dopri5
from .solvers.ode import Kvaerno5 as Kvaerno5
from .solvers.ode import Tsit5 as Tsit5
from .solvers.radau import Radau5 as Radau5
from .analyses.simulate import RunOptions as RunOptions
from .analyses.simulate import SaveAt as SaveAt
from .analyses.simulate import simulate as simulate
from .analyses.sweep import SweepResult as SweepResult
from .analyses.sweep import sweep as sweep
from .analyses.result import Result as Result
from .analyses.result import read_store as read_store
from .analyses.equilibrium import Equilibrium as Equilibrium
from .analyses.equilibrium import solve_equilibrium as solve_equilibrium
from .analyses.linearize import LinearModel as LinearModel
from .analyses.linearize import linearize as linearize
from .model.contacts import CylinderContact as CylinderContact
from .model.contacts import PointContact as PointContact
from .model.contacts import SphereContact as SphereContact
from .model.control import PID as PID
from .model.control import DiscreteController as DiscreteController
from .model.control import HydraulicActuator as HydraulicActuator
from .model.control import JointActuator as JointActuator
from .model.control import Motion as Motion
from .model.laws import FourierLaw as FourierLaw
from .model.laws import SplineLaw as SplineLaw
from .model.laws import Step5Chain as Step5Chain
from .model.control import TranslationalActuator as TranslationalActuator
from . import fn as fn
from .model.control import StateMachine as StateMachine
from .model.control import Battery as Battery
from .model.couplers import Coupler as Coupler
from .model.couplers import JointStop as JointStop
from .model.couplers import JointFriction as JointFriction
from .model.friction import SlideFriction as SlideFriction
from .model.forces import RotationalBacklash as RotationalBacklash
from .model.flexible import FlexibleBody as FlexibleBody


def __getattr__(name):
    """``proleg.robots``, ``proleg.papers``, ``proleg.study``, ``proleg.io`` and ``proleg.report``
    load on first use: they import pandas, pydantic, matplotlib and the robots' data, which a
    model of one's own does not need (``import proleg`` stays short); ``proleg.io.load_urdf(...)``
    works without an ``import proleg.io`` first."""
    if name in ("robots", "papers", "study", "io", "report"):
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'proleg' has no attribute '{name}'")
