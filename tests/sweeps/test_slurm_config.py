"""The ready-to-edit SLURM launcher config (conf/hydra/launcher/slurm_cluster.yaml) composes
into submitit's SLURM launcher with its edits applied and overridable."""

from __future__ import annotations

from extras import needs


@needs("hydra_plugins.hydra_submitit_launcher", "submitit")
def test_slurm_cluster_config_composes_on_submitit_slurm(registry):
    from hydra import compose, initialize_config_module
    from hydra.core.global_hydra import GlobalHydra

    from vpid_bench.shell.config_store import register_configs

    register_configs(registry)
    GlobalHydra.instance().clear()
    with initialize_config_module(version_base="1.3", config_module="vpid_bench.conf"):
        cfg = compose(config_name="config", return_hydra_config=True,
                      overrides=["hydra/launcher=slurm_cluster", "hydra.launcher.partition=short",
                                 "hydra.sweep.dir=/shared/study"])
    GlobalHydra.instance().clear()
    launcher = cfg.hydra.launcher
    assert launcher._target_.endswith("submitit_launcher.SlurmLauncher")
    assert launcher.partition == "short"  # the command line wins over the file
    assert (launcher.cpus_per_task, launcher.mem_gb, launcher.array_parallelism) == (2, 2, 64)
    assert launcher.submitit_folder == "/shared/study/.submitit/%j"
    assert any("activate" in line for line in launcher.setup)
