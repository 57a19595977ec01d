"""eigenmpm.plots writes its figures and closes them, also when drawing fails."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from yade import pack  # noqa: E402

import eigenmpm as em  # noqa: E402
from eigenmpm import plots  # noqa: E402


@pytest.mark.parametrize("h", [0.005, 0.001])  # scattered points, and the raster beyond 8000 points
def test_figures_are_written_and_closed(tmp_path, h):
    plt.close("all")
    mpm = em.MpmEngine(h=h)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=1e9, nu=0.2, rho=1000))
    mpm.crack([(-0.001, 0.025, 0), (0.05, 0.025, 0)])
    plots.damageMap(mpm, str(tmp_path / "damage.png"))
    plots.series(str(tmp_path / "energy.png"), [0.0, 1e-6], {"kinetic": [0.0, 1.0]}, hlines=((0.5, "half"),))
    assert (tmp_path / "damage.png").stat().st_size > 0 and (tmp_path / "energy.png").stat().st_size > 0
    assert plt.get_fignums() == []


def test_a_figure_that_fails_is_closed_too(tmp_path):
    plt.close("all")
    with pytest.raises(ValueError):
        plots.series(str(tmp_path / "bad.png"), [0.0, 1.0, 2.0], {"wrong length": [1.0]})
    assert plt.get_fignums() == [] and not (tmp_path / "bad.png").exists()
