//! `plotd render` on bad `[[surface]]` and `[[ridgeline]]` input (issue 6):
//! every case exits with code 1 and a message naming the scene file, the
//! table and field, and where in the data it went wrong; nothing panics and
//! no output is written.

use std::process::Command;

const CAMERA: &str = "[camera]\neye = [5.0, -6.5, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 35.0\n\n";

/// One case: the object table (after the camera), the data files it reads,
/// and the fragments the error message must contain.
struct Case {
    name: &'static str,
    table: &'static str,
    files: &'static [(&'static str, &'static str)],
    expect: &'static [&'static str],
}

const CASES: &[Case] = &[
    Case {
        name: "ragged csv",
        table: "[[surface]]\ndata = \"h.csv\"\n",
        files: &[("h.csv", "1,2,3\n4,5,6\n7,8\n")],
        expect: &["surface[0].data", "h.csv:3: column 3", "row has 2 values, expected 3"],
    },
    Case {
        name: "non-numeric csv",
        table: "[[surface]]\ndata = \"h.csv\"\n",
        files: &[("h.csv", "1,2,3\n4,five,6\n")],
        expect: &["surface[0].data", "h.csv:2: column 2", "`five` is not a number"],
    },
    Case {
        name: "non-numeric csv header",
        table: "[[surface]]\ndata = \"h.csv\"\n",
        files: &[("h.csv", ",0,1,x2\n0,1,2,3\n1,4,5,6\n")],
        expect: &["surface[0].data", "h.csv:1: column 4"],
    },
    Case {
        name: "one point along x (expression)",
        table: "[[surface]]\nz = \"x * y\"\nx = { values = [0.5] }\ny = { from = 0.0, to = 1.0 }\n",
        files: &[],
        expect: &["surface[0].x", "at least 2"],
    },
    Case {
        name: "zero steps along y",
        table: "[[surface]]\nz = \"x * y\"\nx = { from = 0.0, to = 1.0 }\ny = { from = 0.0, to = 1.0, steps = 0 }\n",
        files: &[],
        expect: &["surface[0].y.steps", "at least 2"],
    },
    Case {
        name: "one column of data",
        table: "[[surface]]\ndata = \"h.csv\"\n",
        files: &[("h.csv", "1\n2\n3\n")],
        expect: &["surface[0].x", "at least 2"],
    },
    Case {
        name: "non-increasing x values",
        table: "[[surface]]\nz = \"x\"\nx = { values = [0.0, 1.0, 1.0, 2.0] }\ny = { from = 0.0, to = 1.0 }\n",
        files: &[],
        expect: &["surface[0].x.values[2]", "strictly increasing", "x[2] = 1 after 1"],
    },
    Case {
        name: "decreasing y values in the csv header column",
        table: "[[surface]]\ndata = \"h.csv\"\n",
        files: &[("h.csv", ",0,1\n1,1,2\n0,3,4\n")],
        expect: &["surface[0].data", "h.csv", "header y coordinates", "strictly increasing"],
    },
    Case {
        name: "expression that does not parse",
        table: "[[surface]]\nz = \"sin(x) + * y\"\nx = { from = 0.0, to = 1.0 }\ny = { from = 0.0, to = 1.0 }\n",
        files: &[],
        expect: &["surface[0].z", "at character 10", "sin(x) + * y\n", "         ^"],
    },
    Case {
        name: "unknown function",
        table: "[[surface]]\nz = \"x + sinc(y)\"\nx = { from = 0.0, to = 1.0 }\ny = { from = 0.0, to = 1.0 }\n",
        files: &[],
        expect: &["surface[0].z", "sinc", "at character 5"],
    },
    Case {
        name: "NaN at a grid point",
        table: "[[surface]]\nz = \"sqrt(x)\"\nx = { from = -1.0, to = 1.0, steps = 2 }\ny = { from = 0.0, to = 1.0 }\n",
        files: &[],
        expect: &["surface[0].z", "NaN at the grid point x = -1, y = 0"],
    },
    Case {
        name: "infinity at a grid point",
        table: "[[surface]]\nz = \"1 / (x - 0.5)\"\nx = { from = 0.0, to = 1.0, steps = 4 }\ny = { from = 0.0, to = 1.0 }\n",
        files: &[],
        expect: &["surface[0].z", "inf at the grid point x = 0.5, y = 0"],
    },
    Case {
        name: "ragged ridgeline csv",
        table: "[[ridgeline]]\ndata = \"r.csv\"\n",
        files: &[("r.csv", "0,1,0,1\n0,2,0\n")],
        expect: &["ridgeline[0].data", "r.csv:2: column 4"],
    },
    Case {
        name: "non-numeric ridgeline csv",
        table: "[[ridgeline]]\ndata = \"r.csv\"\n",
        files: &[("r.csv", "0,1,0\n0,2,?\n")],
        expect: &["ridgeline[0].data", "r.csv:2: column 3", "is not a number"],
    },
    Case {
        name: "one point per ridgeline profile",
        table: "[[ridgeline]]\ndata = \"r.csv\"\n",
        files: &[("r.csv", "1\n2\n")],
        expect: &["ridgeline[0].data", "at least 2 points"],
    },
];

#[test]
fn bad_grid_input_exits_1_with_a_located_message() {
    let mut failures = Vec::new();
    for case in CASES {
        let temp = crate::case_dir("grid-errors", case.name);
        let dir = temp.path();
        let scene = dir.join("scene.toml");
        std::fs::write(&scene, format!("{CAMERA}{}", case.table)).unwrap();
        for (file, text) in case.files {
            std::fs::write(dir.join(file), text).unwrap();
        }
        let out = dir.join("out.svg");
        let o = Command::new(env!("CARGO_BIN_EXE_plotd")).arg("render").arg(&scene).arg("-o").arg(&out).output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        // The object table starts on line 6, after the camera.
        let located = format!("{}:6: ", scene.display());
        let mut problems = Vec::new();
        if o.status.code() != Some(1) {
            problems.push(format!("exit code {:?}", o.status.code()));
        }
        if stderr.contains("panicked") {
            problems.push("panicked".to_string());
        }
        if !stderr.contains(&located) {
            problems.push(format!("does not name `{located}`"));
        }
        for e in case.expect {
            if !stderr.contains(e) {
                problems.push(format!("lacks `{e}`"));
            }
        }
        if out.exists() {
            problems.push("wrote the output".to_string());
        }
        if !problems.is_empty() {
            failures.push(format!("{}: {}\n{stderr}", case.name, problems.join(", ")));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
