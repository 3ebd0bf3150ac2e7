"""The model gives the same integers whether a run is fed whole or in pieces."""

import numpy as np

from rast.sim import scenario


def test_model_outputs_do_not_depend_on_chunking(monkeypatch):
    sc = scenario.random_scenario(4, seed=3)
    whole = scenario.model_outputs(sc)
    monkeypatch.setattr(scenario, "MODEL_CHUNK", 743)
    pieces = scenario.model_outputs(sc)
    assert len(whole[0]) > 10 * 743
    np.testing.assert_array_equal(whole[0], pieces[0])
    np.testing.assert_array_equal(whole[1], pieces[1])
    assert whole[2] == pieces[2]
