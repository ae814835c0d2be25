//! Unit tests of the library, scene area: moved from `#[cfg(test)]` modules beside the code (docs/testing.md).

/// The tests of `scene::budget` (`src/scene/budget.rs`).
mod budget {
    use flexsurf::scene::budget::*;

    #[test]
    fn sizes_parse_and_print() {
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("16GiB").unwrap(), 16 << 30);
        assert_eq!(parse_size("1.5g").unwrap(), 3 << 29);
        assert_eq!(parse_size("1000").unwrap(), 1000);
        assert!(parse_size("lots").is_err() && parse_size("-1G").is_err() && parse_size("1e400").is_err());
        assert_eq!(human(3 << 30), "3.0 GiB");
        assert_eq!(human(12), "12 B");
    }
}

/// The tests of `scene::spans` (`src/scene/spans.rs`).
mod spans {
    use flexsurf::scene::spans::*;

    #[test]
    fn quoted_values_are_removed_from_foreign_messages() {
        assert_eq!(
            sanitize("unknown variant `secret`, expected one of `a`, `b`"),
            "unknown variant, expected one of `a`, `b`"
        );
        assert_eq!(sanitize("unknown field `bendng`, expected `a`"), "unknown field `bendng`, expected `a`");
        assert_eq!(sanitize("invalid type: string \"hunter2\", expected f64"), "invalid type: string, expected f64");
        assert_eq!(sanitize("invalid value: integer `-3`, expected usize"), "invalid value: integer, expected usize");
        assert_eq!(sanitize("invalid string\nexpected `\"`"), "invalid string");
    }

    #[test]
    fn paths_of_values_and_headers() {
        let t = "gravity = [0, 0, -9.81]\n[time]\ndt = -1.0 # s\n[[obstacle]]\nsphere = { center = [0, 0, 0], radius = 0.3 }\n[[obstacle]]\nplane = { point = [0, 0, 0], normal = [0, 0, 1] }\n";
        let at = |s: &str| t.find(s).unwrap();
        assert_eq!(key_at(t, at("-9.81")), "gravity");
        assert_eq!(key_at(t, at("-1.0")), "time.dt");
        assert_eq!(key_at(t, at("0.3")), "obstacle[0].sphere.radius");
        assert_eq!(key_at(t, at("normal") + 10), "obstacle[1].plane.normal");
        assert_eq!(line_col(t, at("-1.0")), (3, 6));
        let u = "[[obstacle]]\nsphere = { centre = [0, 0, 0] }\n[sheet]\nnodes = [\n  21,\n  2,\n]\nsizes = 1\n";
        assert_eq!(key_at(u, u.find("centre").unwrap()), "obstacle[0].sphere.centre");
        assert_eq!(key_at(u, u.find("2,").unwrap()), "sheet.nodes");
        assert_eq!(key_at(u, u.find("sizes").unwrap()), "sheet.sizes");
    }

    /// A missing field of the top-level table was reported under the first key of the file (`material.free`
    /// for a fit problem without `[free]` whose first line set `material`): the parser's span for the top-level
    /// table is empty at offset 0, which is also where the first key starts.
    #[test]
    fn regression_a_missing_top_level_field_took_the_first_key_s_path() {
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Root {
            material: String,
            free: u32,
            time: Option<Time>,
        }
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Time {
            dt: f64,
            steps: u32,
        }
        for (text, key, line) in [
            ("material = \"x\"\nunits = 3\n", "free", 1),
            ("\n\nmaterial = \"x\"\n[time]\ndt = 1.0\nsteps = 2\n", "free", 1),
            ("material = \"x\"\nfree = 1\n[time]\ndt = 1.0\n", "time.steps", 3),
        ] {
            let e = toml::from_str::<Root>(text).unwrap_err();
            let (l, _, k, message) = locate(text, &e);
            assert_eq!((k.as_str(), l), (key, line), "{text:?}: {message}");
        }
    }

    /// The hand-written locator this replaces sliced text at byte offsets and panicked on a non-ASCII key or a
    /// byte-order mark (issue 11: 356 of 365 fuzzer panics).
    #[test]
    fn regression_non_ascii_key_and_bom_do_not_panic() {
        for text in [
            "\u{feff}[time]\ndt = 0.01\n",
            "[time]\nd\u{e9}t = 0.01\nsteps = 1\n",
            "[ti\u{e9}me]\nx = \"\u{1F600}\" = 3\n",
            "\u{feff}",
            "[[obstacle]]\nsph\u{e8}re = { r\u{e4}dius = 0.3 }\n",
        ] {
            for offset in 0..=text.len() + 2 {
                let _ = key_at(text, offset);
                let _ = line_col(text, offset);
            }
        }
        let t = "[time]\nd\u{e9}t = 0.01\n";
        assert_eq!(key_at(t, t.find("d\u{e9}t").unwrap() + 1), "time.d\u{e9}t");
        assert_eq!(line_col(t, t.find(" = 0.01").unwrap()), (2, 4));
    }
}
