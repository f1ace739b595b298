"""Table 2's caption names where a run's model departs from the paper's description."""
from saltstudy.config import load_case, load_fidelity, resolve_scene
from saltstudy.report.tables import model_departures


def _scene(overrides: dict | None = None, fidelity: str = "paper") -> dict:
    case = load_case(2, overrides or {}) if overrides else load_case(2)
    return resolve_scene(case, load_fidelity(fidelity)).model_dump(mode="json")


def test_a_paper_case_at_the_paper_fidelity_departs_in_its_viscosity_filter_and_parcel_weight():
    """The stock case at the paper fidelity: one eddy viscosity and Scotti's filter length (the
    defaults) and the paper's rule for the parcel count (~2,000 airborne per m2), which at the
    model's load is another weight than the paper's Q; nothing else."""
    lines = model_departures(_scene())
    assert len(lines) == 3
    assert "closure.viscosity" in lines[0] and "closure.delta" in lines[1]
    assert "2000 airborne parcels per m2" in lines[2]
    fine = model_departures(_scene({"closure": {"viscosity": "anisotropic", "delta": "geometric"}},
                                   fidelity="fine"))
    assert not any("parcels" in line or "viscosity" in line or "delta" in line for line in fine)


def test_scottis_filter_length_is_named_and_the_geometric_mean_is_not():
    scotti = " ".join(model_departures(_scene({"closure": {"delta": "scotti"}}, "fine")))
    geometric = " ".join(model_departures(_scene({"closure": {"delta": "geometric"}}, "fine")))
    assert "closure.delta" in scotti and "closure.delta" not in geometric


def test_one_eddy_viscosity_is_named_against_eq_a1s_pair():
    one = " ".join(model_departures(_scene({"closure": {"viscosity": "isotropic"}}, "fine")))
    pair = " ".join(model_departures(_scene({"closure": {"viscosity": "anisotropic"}}, "fine")))
    assert "closure.viscosity" in one and "closure.viscosity" not in pair


def test_each_departure_is_named_by_its_config_field():
    text = " ".join(model_departures(_scene({"closure": {"model": "dynamic"},
                                                  "splash": {"impact_speed": "normal"}},
                                                 fidelity="reduced")))
    assert "dynamic" in text
    assert "splash.impact_speed" in text
    assert f"{load_fidelity('reduced').q_multiplier:g}x heavier" in text
    assert "lowered to the level" in text and "relaxation" not in text
    relaxed = " ".join(model_departures(_scene({}, fidelity="reduced-relaxed")))
    assert "relaxation" in relaxed and "lowered to the level" not in relaxed


def test_the_reduced_grid_is_named_and_the_fine_rungs_is_not():
    reduced = " ".join(model_departures(_scene(fidelity="convergence/reduced-q4")))
    assert "first level of 2 cm" in reduced and "horizontal spacing of 0.156 m" in reduced
    fine = " ".join(model_departures(_scene(fidelity="fine")))
    assert "first level" not in fine and "horizontal spacing" not in fine


def test_second_order_advection_is_named_and_the_papers_fourth_order_is_not():
    assert any("second-order horizontal advection" in d
               for d in model_departures(_scene(fidelity="reduced")))
    assert not any("advection" in d for d in model_departures(_scene(fidelity="paper")))
    assert not any("advection" in d for d in model_departures(_scene(fidelity="investigations/streamers-advection/reduced-adv4")))
