"""The single-wheel soil check figure: sinkage, drawbar pull and torque against slip."""

from __future__ import annotations

from offroadbench.plots.style import new_figure

__all__ = ["plot_soil_check"]


def plot_soil_check(rig, model, title: str = ""):
    """Three panels against slip: the engine rig (markers) beside the Wong-Reece integrals (line);
    ``rig`` and ``model`` are offroadbench.sim.rigs.soil_check.SoilCheck."""
    fig, axes = new_figure(1, 3, figsize=(11.0, 3.4))
    panels = (("sinkage_m", 1000.0, "sinkage, mm"), ("drawbar_pull_n", 1.0, "drawbar pull, N"),
              ("torque_nm", 1.0, "driving torque, N m"))
    for ax, (field, scale, label) in zip(axes, panels):
        ax.plot(model.slip, scale * getattr(model, field), "-", color="#1f5fbf", label="Wong-Reece integrals")
        ax.plot(rig.slip, scale * getattr(rig, field), "o", color="#f08c1a", mfc="none", label="engine rig")
        ax.set_xlabel("slip")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title or f"{rig.soil}: wheel r = {rig.radius_m:g} m, b = {rig.width_m:g} m, load {rig.load_n:.1f} N",
                 fontsize=10)
    return fig
