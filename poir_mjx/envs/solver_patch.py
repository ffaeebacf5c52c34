"""A small, version-checked patch of MJX's constraint solver (``mujoco/mjx/_src/solver.py``), applied only while
an environment whose ``PhysicsConfig`` asks for it is traced (``physics.solver_scope``).

The line search. MJX runs Newton's line search through ``_while_loop_scan``: a ``lax.scan`` of ``ls_iterations``
steps, each a ``lax.cond`` that skips the step once the search has converged. Under ``vmap`` (every batched step)
``cond`` becomes ``select``, so all ``ls_iterations`` steps run in every Newton iteration, about 5 of them useful
(issue 42). ``while_loop_bounded`` has the same signature and the same result (the same body applied the same
number of times, at most ``max_iter``) as a ``lax.while_loop``: under ``vmap`` it stops when the batch's slowest
search has converged. What it gives up is reverse-mode differentiation through the line search, the reason MJX
chose the scan; nothing in this project differentiates through the physics.

As an upstream change it is one line in ``_linesearch`` (3.3.7 to 3.17.0; ``cond`` there already stops at
``m.opt.ls_iterations``)::

    ls_ctx = jax.lax.while_loop(cond, body, ls_ctx)  # was: _while_loop_scan(cond, body, ls_ctx, ...)

perhaps behind an option for those who need reverse-mode gradients.

The elliptic-cone Hessian. With Newton and elliptic cones MJX's ``_update_gradient`` assembles a dense
nefc x nefc matrix C (the active rows' D on the diagonal plus one scattered condim x condim cone block per
contact, each an unrolled scatter) and multiplies J^T C J: nefc is 290 for Lift, 1234 for PickPlaceCan.
``update_gradient_blocks`` computes the same H = M + J^T diag(D active) J + sum_c J_c^T H_c J_c, gathering each
contact's rows once per contact dimension; it replaces ``_update_gradient`` (same signature) and defers to MJX's
own for other solvers and cones.

The patch is written for, and refuses anything but, the mujoco-mjx versions in ``SUPPORTED_MJX``: their
``_while_loop_scan`` (and its one caller) and ``_update_gradient`` are the same code (3.17.0's checked against
its wheel).
"""

from __future__ import annotations

import contextlib
import functools
import threading

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.typed_config import ConfigError
from poir_mjx.versions import mjx_version

SUPPORTED_MJX = ("3.3.7", "3.17.0")
_LOCK = threading.RLock()  # one patched trace at a time: the patch swaps module attributes


class UnsupportedMJXError(ConfigError):
    """The installed mujoco-mjx is not one the solver patch was written for."""


def check_version(version: str | None = None) -> None:
    """Refuse (UnsupportedMJXError) a mujoco-mjx version the patch was not written for."""
    v = mjx_version() if version is None else version
    if v not in SUPPORTED_MJX:
        raise UnsupportedMJXError(
            f"physics: the MJX solver patch (linesearch_loop 'while', cone_hessian 'blocks') was written for "
            f"mujoco-mjx {' and '.join(SUPPORTED_MJX)}, this is {v}; use linesearch_loop 'scan' and cone_hessian "
            "'dense' (MJX as it is)"
        )


def while_loop_bounded(cond_fun, body_fun, init_val, max_iter):
    """``lax.while_loop`` with at most `max_iter` bodies: MJX's ``_while_loop_scan`` contract (the same result)
    without the scan, so that under ``vmap`` the loop ends when every lane's `cond_fun` is false."""

    def cond(carry):
        i, val = carry
        return (i < max_iter) & cond_fun(val)

    def body(carry):
        i, val = carry
        return i + 1, body_fun(val)

    return jax.lax.while_loop(cond, body, (0, init_val))[1]


def update_gradient_blocks(m, d, ctx, original):
    """MJX's ``_update_gradient`` with Newton's elliptic-cone Hessian assembled per contact block: H = M + J^T
    diag(D * active) J + sum over cone contacts c of J_c^T H_c J_c, where J_c are contact c's condim rows of
    efc_J and H_c its cone Hessian (``ctx.h``). MJX builds the same sum as J^T C J with C a dense nefc x nefc
    matrix (diag(D * active) plus one scattered block per contact): O(nefc^2 nv) work and nefc^2 memory per
    episode, against O(nefc nv^2) here. Same maths, another summation order. Other solvers and cones: `original`.
    """
    from mujoco.mjx._src import support
    from mujoco.mjx._src.types import ConeType, SolverType

    if m.opt.solver != SolverType.NEWTON or m.opt.cone != ConeType.ELLIPTIC:
        return original(m, d, ctx)
    impl = d._impl
    grad = ctx.Ma - d.qfrc_smooth - ctx.qfrc_constraint
    efc_j = impl.efc_J
    h = (efc_j.T * (impl.efc_D * ctx.active)) @ efc_j
    cone = np.asarray(impl.contact.dim) > 1
    dim, adr = np.asarray(impl.contact.dim)[cone], np.asarray(impl.contact.efc_address)[cone]
    for condim in np.unique(dim):  # one gather and one contraction per contact dimension (static)
        sel = np.flatnonzero(dim == condim)
        j_c = efc_j[adr[sel, None] + np.arange(condim)]  # [contacts, condim, nv]
        h_c = ctx.h[sel, :condim, :condim]
        h = h + jnp.einsum("cin,cij,cjm->nm", j_c, h_c, j_c)
    h = support.full_m(m, d) + h
    h_sym = (h + h.T) * 0.5  # as MJX: symmetrised for the Cholesky factorisation
    mgrad = jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(h_sym), grad)
    return ctx.replace(grad=grad, Mgrad=mgrad)


@contextlib.contextmanager
def patched(while_linesearch: bool = True, block_hessian: bool = False):
    """Within this scope MJX's solver, as traced, uses the patched pieces asked for (nothing else changes).

    The swap is of module attributes of ``mujoco.mjx._src.solver``, restored on exit; a lock keeps two patched
    traces from interleaving. Code traced outside the scope (or compiled before it) is unaffected."""
    check_version()
    from mujoco.mjx._src import solver

    with _LOCK:
        saved = solver._while_loop_scan, solver._update_gradient
        try:
            if while_linesearch:
                solver._while_loop_scan = while_loop_bounded
            if block_hessian:
                solver._update_gradient = functools.partial(update_gradient_blocks, original=saved[1])
            yield
        finally:
            solver._while_loop_scan, solver._update_gradient = saved
