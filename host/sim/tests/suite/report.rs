//! The demo's reports on a small hand-made [`Report`]: `report.html` passes the strict check
//! and says what `report.md` says, markup in a name is escaped, and the check itself refuses
//! what a browser would read otherwise (the full demo's reports: the CLI's demo test).

use fsm_scan::metrics::{ColumnErrors, Comparison, PointErrors};
use fsm_sim::comparison::{html, markdown, GlossyFigures, MethodReport, Report, SphereFigures};

use crate::support::{read_html, read_markdown, Block, Picture};

/// The interreflection picture's text alternative.
const INTERREFLECTION: &str =
    "plane_mirror's camera pixels, white where more than 20% of the light comes through the mirror";

/// A method name with every character HTML escapes.
const MARKUP: &str = r#"A<&>"B"#;

fn method(name: &'static str, k: f64) -> MethodReport {
    let columns = ColumnErrors {
        pixels: 100,
        decoded: 99,
        rms_columns: 0.05 * k,
        within_half_column: 0.9 / k,
        rms_all_columns: 0.1 * k,
    };
    let points = PointErrors {
        wrong_beyond_mm: 1.0,
        points: 1000,
        wrong: (10.0 * k) as usize,
        lit: 900,
        lit_right: 890,
    };
    MethodReport {
        method: name,
        patterns: 152,
        figures: Comparison {
            interreflection: columns,
            interreflection_covered: columns,
            surface: columns,
            e_d_mm: 0.01 * k,
            e_no_i_mm: 0.008 * k,
            e_wi_i_mm: 0.009 * k,
            completeness: 0.97,
        },
        points,
        e_d_percent_of_standoff: 0.002 * k,
        e_no_i_percent_of_standoff: 0.0016 * k,
        e_wi_i_percent_of_standoff: 0.0018 * k,
        sphere: SphereFigures {
            points,
            behind_mirror: 200,
            mirrors: 1,
        },
        glossy: GlossyFigures {
            pixels: 500,
            direct_among_candidates: 0.97,
            completeness: 0.95 / k,
            points_within_half_column: 0.93,
            points,
        },
        seconds: 1.5,
    }
}

fn report() -> Report {
    Report {
        camera: [32, 24],
        standoff_mm: 500.0,
        seed: 1,
        interreflection_pixels: 123,
        methods: vec![method("BFSM", 1.0), method(MARKUP, 2.0), method("LS", 3.0)],
    }
}

#[test]
fn the_html_report_says_what_the_markdown_report_says() {
    let report = report();
    let page = read_html(&html(&report)).unwrap_or_else(|e| panic!("{e}\n{}", html(&report)));
    let md = read_markdown(&markdown(&report));
    assert_eq!(page, md);
    assert_eq!(
        page.title,
        "fsm demo: a mirror's interreflection, 3 methods"
    );
    // The headings and code spans, the figures of a row, every picture.
    assert!(page.blocks.contains(&Block::Heading(
        "Glossy interreflection: vgroove_glossy".into()
    )));
    assert!(page.blocks.contains(&Block::Heading(
        "A mirror that lights a curved surface and shows the wall: sphere_mirror".into()
    )));
    let tables = page.tables();
    assert_eq!(tables.len(), 4, "{tables:?}");
    assert_eq!(
        tables[1].1[2],
        ["LS", "1000", "3.00%", "98.89%", "1", "200"],
        "the sphere_mirror table"
    );
    let (header, rows) = tables[0];
    assert_eq!(header[4], "Ed mm (% standoff)");
    assert_eq!(
        rows[1],
        [
            MARKUP,
            "152",
            "45.00%",
            "0.1000 (0.1000)",
            "0.0200 (0.0040%)",
            "0.0160",
            "0.0180",
            "97.0%",
            "2.00%",
            "98.89%"
        ]
    );
    let pictures = page.pictures();
    assert_eq!(pictures.len(), 1 + 3 * 5);
    assert_eq!(
        pictures[0],
        Picture {
            src: "interreflection.png".into(),
            alt: INTERREFLECTION.into()
        }
    );
    // The method's name is markup: percent-encoded in the link, the same file decoded.
    let depth = Picture {
        src: "a%3C%26%3E%22b/plane_mirror/depth.png".into(),
        alt: format!("{MARKUP}: depth with the mirror"),
    };
    assert!(pictures.contains(&depth), "{pictures:?}");
    assert_eq!(depth.file(), r#"a<&>"b/plane_mirror/depth.png"#);
}

#[test]
fn markup_in_a_name_is_escaped() {
    let page = html(&report());
    assert!(!page.contains(MARKUP), "{page}");
    assert!(page.contains("<td>A&lt;&amp;&gt;&quot;B</td>"), "{page}");
    assert!(
        page.contains(r#"src="a%3C%26%3E%22b/column_error.png""#),
        "{page}"
    );
    // Prose: `&` escaped, code spans as <code>.
    assert!(page.contains("(Gupta &amp; Nayar)"), "{page}");
    assert!(
        page.contains("<code>&lt;method&gt;/&lt;scene&gt;/</code>"),
        "{page}"
    );
}

/// `page` with the first `from` replaced by `to` (which must be there).
fn mutated(page: &str, from: &str, to: &str) -> String {
    assert!(page.contains(from), "no {from:?} in the page");
    page.replacen(from, to, 1)
}

#[test]
fn the_check_refuses_a_row_with_a_missing_cell() {
    let page = html(&report());
    read_html(&page).unwrap();
    // The main table's first row without its patterns cell.
    let short = mutated(&page, "<tr><td>BFSM</td><td>152</td>", "<tr><td>BFSM</td>");
    let error = read_html(&short).unwrap_err();
    assert!(
        error.contains("row 1") && error.contains("9 cells, its header 10"),
        "{error}"
    );
    let long = mutated(&page, "<td>152</td>", "<td>152</td><td>1</td>");
    assert!(read_html(&long).unwrap_err().contains("11 cells"));
}

#[test]
fn the_check_refuses_what_a_browser_would_read_otherwise() {
    let page = html(&report());
    let title = "<title>fsm demo: a mirror's interreflection, 3 methods</title>";
    let alt = format!(" alt=\"{INTERREFLECTION}\"");
    let caption = "<figcaption><code>interreflection.png</code></figcaption>";
    // What is changed, into what, and what the check must say.
    let cases = [
        ("<!DOCTYPE html>\n", "", "before <!DOCTYPE html>"),
        ("Gupta &amp; Nayar", "Gupta & Nayar", "not well-formed"),
        ("Gupta &amp; Nayar", "Gupta&nbsp;&amp; Nayar", "&nbsp;"),
        (
            "<meta charset=\"utf-8\" />",
            "<meta charset=\"utf-8\">",
            "write <meta />",
        ),
        ("<td>152</td>", "<td />", "HTML reads it as an open tag"),
        ("lang=\"en\"", "lang=en", "must be enclosed"),
        (
            "lang=\"en\"",
            "lang=\"en\" lang=\"fr\"",
            "duplicated attribute",
        ),
        (&alt, " alt=\"\"", "without a non-empty alt"),
        (&alt, "", "without a non-empty alt"),
        (
            "src=\"",
            "src=\"https://example.org/",
            "not a relative link",
        ),
        ("src=\"", "src=\"../", "not a relative link"),
        (
            "</body>",
            "<script>alert(1)</script></body>",
            "<body> holds a <script>",
        ),
        ("<body>", "<body onload=\"x()\">", "the attribute onload"),
        (
            "<style>",
            "<style>@import \"x.css\";",
            "<style> loads something",
        ),
        ("<p>Ed:", "<p><table></table>Ed:", "<p> holds a <table>"),
        ("<thead>", "x<thead>", "<table> holds the text"),
        (
            "<tbody>",
            "<tr><td>1</td></tr><tbody>",
            "<table> holds a <tr>",
        ),
        ("</figcaption>", "", "not well-formed"),
        (
            "</code></figcaption>",
            "</figcaption></code>",
            "not well-formed",
        ),
        (title, "", "one non-empty <title>"),
        ("<meta charset=\"utf-8\" />", "", "charset"),
        (caption, "", "<figcaption>"),
        (
            "<a href=\"interreflection.png\">",
            "<a href=\"x.png\">",
            "around another picture",
        ),
    ];
    for (from, to, says) in cases {
        let error = read_html(&mutated(&page, from, to))
            .err()
            .unwrap_or_else(|| panic!("{from:?} as {to:?} accepted"));
        assert!(error.contains(says), "{from:?} as {to:?}: {error}");
    }
}

#[test]
fn the_demo_announces_the_scenes_it_runs() {
    let system = fsm_sim::System::bench_with_camera(64, 48);
    assert_eq!(
        fsm_sim::comparison::announcement(&system),
        "simulating plane_mirror, plane_mirror_covered, sphere_mirror and vgroove_glossy (64x48 camera)…"
    );
}

#[test]
fn the_demo_ends_with_where_its_report_is() {
    let line = fsm_sim::comparison::reports_written(std::path::Path::new("fsm-demo"));
    assert_eq!(
        line,
        "report in fsm-demo/report.html (and report.md, report.json beside it)"
    );
}
