//! The report's replays: a few scenes of `scenes/` run with the default method and
//! written as [`constraint_scene::scene_view`] pages beside the report, so `report.html` shows each
//! one moving (the converter in [`crate::html`] embeds a linked `.html` page as a
//! sandboxed frame). Markdown readers get a link to the page.

use std::fmt::Write as _;
use std::path::Path;

use constraint_scene::run::{run, RunOptions};

/// A replayed scene: report name, file under `scenes/`, keyframe, simulated seconds,
/// and what it shows.
pub struct Replay {
    /// Name of the page (`replay_<name>.html`).
    pub name: &'static str,
    /// MJCF file under `scenes/`.
    pub file: &'static str,
    /// Keyframe to start from (`None`: the file's rest pose).
    pub keyframe: Option<&'static str>,
    /// Simulated duration (s).
    pub duration: f64,
    /// One line on what the replay shows.
    pub caption: &'static str,
}

/// The replays of the report: jointed bodies with limits landing on the floor, a chain
/// whipping under gravity, a chain falling onto the floor, and a box stack at rest, all
/// in the one world.
pub const REPLAYS: [Replay; 4] = [
    Replay {
        name: "ragdoll",
        file: "ragdoll.xml",
        keyframe: Some("start"),
        duration: 2.0,
        caption: "ragdoll dropped on the floor: limited hinges, capsules, contact and friction in one world",
    },
    Replay {
        name: "chain20",
        file: "chain20.xml",
        keyframe: Some("start"),
        duration: 2.0,
        caption: "20-link ball-joint chain released horizontally",
    },
    Replay {
        name: "chain20_floor",
        file: "chain20_floor.xml",
        keyframe: None,
        duration: 2.0,
        caption: "20-link chain falling onto the floor",
    },
    Replay {
        name: "box_stack",
        file: "box_stack.xml",
        keyframe: None,
        duration: 2.0,
        caption: "box stack resting on the floor",
    },
];

/// Runs every [`REPLAYS`] scene from `root/scenes/`, writes `out/replay_<name>.html`
/// and appends a "Replays" section to `md` (one embedded page per scene). A scene that
/// fails to run or draw is reported in the section, not an error: the replays show, they
/// do not check.
pub fn section(md: &mut String, out: &Path, root: &Path) {
    let _ = writeln!(md, "\n## Replays\n");
    let _ = writeln!(
        md,
        "Each scene run with the default method (RATTLE) at the file's step and drawn from \
         its trajectory: drag to orbit, wheel to zoom, space to play or pause. The pages \
         are also beside this report (`replay_<scene>.html`).\n"
    );
    for r in &REPLAYS {
        let path = root.join("scenes").join(r.file);
        let opts = RunOptions {
            keyframe: r.keyframe.map(str::to_string),
            duration: r.duration,
            ..RunOptions::default()
        };
        let page = run(&path, &opts).and_then(|(traj, _)| {
            let model = constraint_mjcf::load_file(&path).map_err(|e| e.to_string())?;
            constraint_scene::scene_view::page(&model, &traj, r.name).map_err(|e| e.to_string())
        });
        let file = format!("replay_{}.html", r.name);
        match page.and_then(|p| std::fs::write(out.join(&file), p).map_err(|e| e.to_string())) {
            Ok(()) => {
                let _ = writeln!(md, "![{}: {}]({file})\n", r.name, r.caption);
            }
            Err(e) => {
                let _ = writeln!(md, "- {}: no replay ({e})\n", r.name);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_replay_runs_and_is_written_and_linked() {
        let out = std::env::temp_dir().join(format!("replays-test-{}", std::process::id()));
        std::fs::create_dir_all(&out).expect("temp dir");
        let mut md = String::new();
        section(&mut md, &out, &crate::articulated_report::root());
        for r in &REPLAYS {
            let file = format!("replay_{}.html", r.name);
            assert!(md.contains(&format!("]({file})")), "{}: {md}", r.name);
            let page = std::fs::read_to_string(out.join(&file)).expect("page written");
            assert!(page.contains("<canvas"), "{}", r.name);
        }
        assert!(!md.contains("no replay"), "{md}");
        // The report page embeds each replay whole (no link left to follow).
        crate::html::write_page(&md, &out, &out.join("report.html")).expect("page");
        let html = std::fs::read_to_string(out.join("report.html")).expect("report");
        assert_eq!(html.matches("<iframe").count(), REPLAYS.len());
        if std::env::var_os("KEEP_REPLAYS").is_none() {
            let _ = std::fs::remove_dir_all(&out);
        }
    }
}
