"""An episode with rendering on takes rendered frames; with it off, its settings (and so every job's id) are as
before rendering existed."""

from __future__ import annotations

from evaluation.campaign import EpisodeSettings, parse_systems, run_episode
from evaluation.campaign.jobs import job_id
from flight.sim.scene_gen import generate_scene


def test_render_off_leaves_the_settings_and_job_ids_unchanged() -> None:
    assert "render" not in EpisodeSettings().model_dump(mode="json")
    assert EpisodeSettings(render=True).model_dump(mode="json")["render"] is True
    (system,) = parse_systems("rules", environ={})
    assert job_id("ab" * 32, system, 0, EpisodeSettings()) != job_id("ab" * 32, system, 0, EpisodeSettings(render=True))


def test_an_episode_with_pixels_runs() -> None:
    scene = generate_scene(3, persons=150, casualties=1, distractors=0, scene_id="px")
    (system,) = parse_systems("rules", environ={})
    (record,) = run_episode(scene, [system], EpisodeSettings(frames=4, assess_every=0, render=True))
    assert record.scene_id == "px" and record.frames == 4 and record.persons_in_view > 0
