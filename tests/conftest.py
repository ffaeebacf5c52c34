import os
from pathlib import Path

# JAX's persistent compilation cache in a local folder: MJX programs take minutes to compile on CPU.
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".cache" / "jax"))
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "1")
# MJX in double precision: in float32 the contact solve launched NutAssemblySquare's 16 g nut
# during a grasp that robosuite (float64) and MJX in float64 both complete (README, "Fidelity").
os.environ.setdefault("JAX_ENABLE_X64", "1")
