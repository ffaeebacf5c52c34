"""The software stack a result names (poir_mjx/versions.py)."""

import mujoco

from poir_mjx import versions


def test_mujoco_version_comes_from_the_module_where_no_mujoco_distribution_exists(monkeypatch):
    """MuJoCo 4 installs the module from split distributions (mujoco-core): no 'mujoco' metadata to read."""
    real = versions.package_version
    monkeypatch.setattr(versions, "package_version", lambda name: None if name == "mujoco" else real(name))
    assert versions.stack()["mujoco"] == mujoco.__version__
    assert f"mujoco {mujoco.__version__}," in versions.stack_line()
    assert f"(MuJoCo {mujoco.__version__})" in versions.simulator_line("robosuite")


def test_precision_is_pinned_on_accelerators_and_recorded(monkeypatch):
    import jax

    from poir_mjx import devices

    before = jax.config.jax_default_matmul_precision
    devices.pin_precision()
    assert jax.config.jax_default_matmul_precision == before and devices.precision_note() == ""  # CPU: untouched
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    try:
        devices.pin_precision()
        assert jax.config.jax_default_matmul_precision == "highest"
        assert versions.simulator_line("mjx").endswith("float32, matmul precision highest)")
    finally:
        jax.config.update("jax_default_matmul_precision", before)
