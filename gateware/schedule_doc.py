"""The slot schedule of the board's default build, for docs/tdm_engine.md:
``python -m rast.gateware.schedule_doc`` prints the table
(``rast.hdl.pipeline.timeline``) that the page holds between its markers."""

from rast.gateware.build import BuildConfig
from rast.hdl.pipeline.timeline import schedule_markdown
from rast.model.contract.fixedpoint import ReplayContract

__all__ = ["default_contract"]


def default_contract() -> ReplayContract:
    """The default build's contract (``BuildConfig()``)."""
    return BuildConfig().contract()


if __name__ == "__main__":
    print(schedule_markdown(default_contract()))
