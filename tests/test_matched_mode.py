"""MatchedMode: the typed record of a matched mode keeps the JSON of the dicts it replaced."""

from __future__ import annotations

import json
import pickle

import pytest

from ema_rig.rig.matched_mode import MatchedMode

# a housing-mode dict as match_modes wrote it before the typed record (key order is the JSON's)
_DICT = {"natural_freq": 626.0, "damping_ratio": 0.012, "natural_freq_std": None, "modal_mass": 2.61,
         "modal_mass_source": "driving point", "model_modal_mass": 2.64, "spindle_ratio": 0.11,
         "model_spindle_ratio": 0.108, "axial_ratio": 0.02, "lateral_ratio": None}


def test_the_mapping_view_is_the_dict_it_replaced() -> None:
    m = MatchedMode.from_mapping(_DICT)
    assert json.dumps(dict(m)) == json.dumps(_DICT)  # same keys, same order, same values (None kept)
    assert m.natural_freq == 626.0 and m["modal_mass"] == 2.61 and m.get("source") is None
    assert m == _DICT  # Mapping equality, as the dict compared
    with pytest.raises(KeyError):
        m["source"]  # not given: absent, as from the dict


def test_with_entries_sets_and_appends_like_a_dict() -> None:
    m = MatchedMode.from_mapping(_DICT).with_entries(natural_freq_std=0.3, source="auto")
    expected = {**_DICT, "natural_freq_std": 0.3, "source": "auto"}
    assert json.dumps(dict(m)) == json.dumps(expected)


def test_unknown_names_are_refused_and_the_record_pickles() -> None:
    with pytest.raises(ValueError, match="unknown MatchedMode entries"):
        MatchedMode.from_mapping({**_DICT, "natral_freq": 1.0})
    m = MatchedMode.from_mapping(_DICT)
    back = pickle.loads(pickle.dumps(m))  # campaign workers send results between processes
    assert dict(back) == dict(m) and back.entries == m.entries


def test_a_failure_is_its_text_with_a_kind() -> None:
    import copy

    from ema_rig.rig.failures import Failure

    f = Failure("mass units", "effective modal mass 25.9 kg, model 2.64 kg (ratio 9.8, allowed 0.5-2): "
                              "accelerations in g read as m/s^2? check the file's units")
    assert json.dumps([f]) == json.dumps([str(f)])  # the JSON of the candidates is unchanged
    for back in (pickle.loads(pickle.dumps(f)), copy.deepcopy(f)):  # workers; dataclasses.asdict
        assert back == f and back.kind == "mass units" and isinstance(back, Failure)
