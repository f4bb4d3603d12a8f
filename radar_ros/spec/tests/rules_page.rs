//! `docs/rules.md` is made from the rules as `radar_spec` states them (`rules::ALL`), so the rules are written
//! once: this test fails when the page and the crate differ, and `RADAR_BLESS=1 cargo test -p radar_spec --test
//! rules_page` writes the page anew.

use radar_spec::rules::{Class, ALL};

fn page() -> String {
    let mut out = String::from(
        "# RADAR's rules\n\n\
         Made from `radar_spec` (`radar_ros/spec/src/rules/mod.rs`), where each rule is written once, by \
         `radar_ros/spec/tests/rules_page.rs` (`RADAR_BLESS=1 cargo test -p radar_spec --test rules_page` writes \
         it anew). The machines of `radar_semantics` carry them out; `radar_checker` and `radar verify` judge \
         traces by them ([checker.md](checker.md)). *Wire*: a recording of the topics can show it (`radar \
         verify`, `radar view`); the others need what happens inside a process (what was read and when, which \
         slot ran) and are judged in the model checker.\n\n\
         | rule | name | kind | wire | what it says |\n|---|---|---|---|---|\n",
    );
    for r in ALL {
        let class = match r.class {
            Class::Safety => "safety",
            Class::Liveness => "liveness",
        };
        let wire = if r.wire { "yes" } else { "" };
        let text = r.text.replace('|', "\\|");
        out.push_str(&format!(
            "| {} | `{}` | {class} | {wire} | {text} |\n",
            r.id, r.name
        ));
    }
    out
}

#[test]
fn the_rules_page_is_made_from_the_rules_the_crate_checks() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/rules.md");
    let want = page();
    if std::env::var("RADAR_BLESS").as_deref() == Ok("1") {
        std::fs::write(&path, &want).unwrap();
    }
    let got = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        got == want,
        "docs/rules.md is not what radar_spec's rules make: run `RADAR_BLESS=1 cargo test -p radar_spec --test \
         rules_page` and commit it"
    );
}

#[test]
fn every_rule_has_a_number_a_unique_name_and_a_text() {
    let mut names: Vec<&str> = ALL.iter().map(|r| r.name).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), ALL.len(), "names are unique");
    for r in ALL {
        let (letter, number) = r.id.split_at(1);
        assert!(
            matches!(letter, "R" | "C" | "E" | "T") && number.parse::<u32>().is_ok(),
            "{}: {}",
            r.name,
            r.id
        );
        assert!(r.text.ends_with('.') && r.text.len() > 40, "{}", r.name);
    }
}
