//! Bugs planted in the machines, one at a time, for the checker to find (its mutation score). Each is a
//! change of the source of `radar_semantics` (a text replaced by another wherever it is in its file), made in a
//! copy of the crates by `radar_mutants`, which then builds the checker against it and explores the scenarios
//! until a rule is broken.

/// A planted bug.
#[derive(Clone, Copy, Debug)]
pub struct Mutant {
    /// Its name.
    pub name: &'static str,
    /// What the bug is, in words.
    pub what: &'static str,
    /// The file of `radar_ros/semantics` it changes.
    pub file: &'static str,
    /// The text it replaces (everywhere in the file; it must be there).
    pub from: &'static str,
    /// What it puts there.
    pub to: &'static str,
}

/// Every planted bug.
pub static MUTANTS: &[Mutant] = &[
    Mutant {
        name: "window-one-delivery-too-long",
        what: "an `until` window stays open past the `exited` of the run it was opened for (C6)",
        file: "src/connection/window.rs",
        from: "self.pending.retain(|&n| n > m);",
        to: "self.pending.retain(|&n| n >= m);",
    },
    Mutant {
        name: "dropped-start-ends-the-run-going",
        what: "a `whenever ... until` takes a later start its response dropped for the end of the earlier run \
               the statement began, so U no longer interrupts that run (C6; issue 69's first fix did this)",
        file: "src/connection/window.rs",
        from: "self.pending.remove(&m);",
        to: "self.pending.retain(|&n| n > m);",
    },
    Mutant {
        name: "once-spent-too-late",
        what: "a `once` is spent on its second delivery, not its first (C2)",
        file: "src/connection/mod.rs",
        from: "                if c.kind == Kind::Once {\n                    c.spent = true;",
        to: "                if c.kind == Kind::Once && c.delivered > 1 {\n                    c.spent = true;",
    },
    Mutant {
        name: "once-spent-on-a-refused-signal",
        what: "a `once` delivers (and is spent on) a signal its filter or target refuses (C2)",
        file: "src/connection/mod.rs",
        from: "if &c.source == source && !c.spent && c.link == Link::Armed && accept(*id) {",
        to: "if &c.source == source && !c.spent && c.link == Link::Armed && (accept(*id) || c.kind == Kind::Once) {",
    },
    Mutant {
        name: "until-released-too-late",
        what: "a spent `once ... until` does not end when the run its start began has exited (C3)",
        file: "src/connection/mod.rs",
        from: "                ours: mine,\n            });\n            over = self.spent && w.settled();",
        to: "                ours: mine,\n            });\n            over = false;",
    },
    Mutant {
        name: "dropped-start-not-ending-the-once",
        what: "a response's `dropped` for a spent `once ... until`'s start does not end it (C3)",
        file: "src/connection/mod.rs",
        from: "            w.apply(WindowSignal::Dropped { ours: mine });\n            over = self.spent && w.settled();",
        to: "            w.apply(WindowSignal::Dropped { ours: mine });",
    },
    Mutant {
        name: "response-leaving-not-ending-the-once",
        what: "a spent `once ... until` whose response left does not end (C3, C5)",
        file: "src/connection/departures.rs",
        from: "        for id in over {\n            self.end(id);\n        }",
        to: "        let _ = over;",
    },
    Mutant {
        name: "exit-slot-skipped-after-an-interrupt",
        what: "an interrupted run emits `exited` without running its exit slot (R2, R7)",
        file: "src/response/mod.rs",
        from: "                self.run_exit(ExitReason::Interrupted, &mut fx);\n            }\n            (Phase::Exiting, Input::ExitEnded(result))",
        to: "                self.exit_ended(Ok(ExitAction::Done), &mut fx);\n            }\n            (Phase::Exiting, Input::ExitEnded(result))",
    },
    Mutant {
        name: "arrival-order-not-cause",
        what: "an interrupt emitted before the run began (read after) interrupts it: arrival order, not cause (R11)",
        file: "src/response/mod.rs",
        from: "_ if s.at < self.began => Err(IgnoreReason::Before),",
        to: "_ if false => Err(IgnoreReason::Before),",
    },
    Mutant {
        name: "kept-signal-not-taken",
        what: "an interrupt that overtook its start is not taken by that start's run (R12)",
        file: "src/response/mod.rs",
        from: "self.held = self.kept.take_for_run(s, self.cause, self.began);",
        to: "let _ = self.kept.take_for_run(s, self.cause, self.began);",
    },
    Mutant {
        name: "until-interrupts-any-run",
        what: "an `until`'s interrupt interrupts a run of another statement (R13)",
        file: "src/response/mod.rs",
        from: "if self.cause.map(|c| c.statement) != Some(by.statement) {",
        to: "if false {",
    },
    Mutant {
        name: "signals-before-arming-delivered",
        what: "a connection delivers signals emitted before it was armed (C1)",
        file: "src/connection/mod.rs",
        from: "            if emitted_at < c.armed_at {\n                continue; // C1\n            }",
        to: "",
    },
    Mutant {
        name: "dropped-start-not-announced",
        what: "a response does not announce a start it did not take (R6)",
        file: "src/response/mod.rs",
        from: "            fx.push(Effect::EmitDropped(c));",
        to: "            let _ = c;",
    },
    Mutant {
        name: "second-process-taken-as-respawn",
        what: "a second live process of one name is taken as a respawn of the first (C5)",
        file: "src/instances.rs",
        from: "Some(new) if live(c) == Liveness::Dead => {",
        to: "Some(new) => {",
    },
    Mutant {
        name: "event-checks-after-its-last-listener",
        what: "an event goes on checking when its last listener leaves (E1)",
        file: "src/event.rs",
        from: "(true, false) => Some(Transition::Deactivate),",
        to: "(true, false) => None,",
    },
    Mutant {
        name: "queue-keeps-the-oldest-start",
        what: "`queue_one` runs the oldest start it queued, not the newest (R6, R1)",
        file: "src/response/mod.rs",
        from: "if let Some((_, old)) = self.pending.replace((p, s)) {",
        to: "if let Some((_, old)) = self.pending.replace((p, s)).map(|kept| self.pending.replace(kept).unwrap()) {",
    },
    Mutant {
        name: "sender-lead-ignored",
        what: "a relay takes a stamp from a clock ahead as now, not by its sender's lead (T1, C1)",
        file: "src/time.rs",
        from: "received(stamp.saturating_sub(self.get()), now)",
        to: "received(stamp, now)",
    },
    Mutant {
        name: "fired-call-not-forgotten",
        what: "a fired `once ... call` whose scope ends is not forgotten: its queued call begins after the scope (C4)",
        file: "src/connection/outcome.rs",
        from: "if let Some(t) = self.ended_calls.remove(&id) {\n            return Some(t);\n        }",
        to: "self.ended_calls.remove(&id);",
    },
    Mutant {
        name: "stop-drops-the-queued-start-silently",
        what: "a response told to stop drops its queued start without announcing it (R6)",
        file: "src/response/stop.rs",
        from: "if let Some((_, s)) = self.pending.take() {\n            Self::dropped(s, &mut fx);\n        }",
        to: "",
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    /// Every planted bug still finds its text (a refactor of the machines that moves it breaks the mutation
    /// run; this says which bug at once), and changes something.
    #[test]
    fn every_mutant_replaces_text_that_is_in_its_file() {
        let semantics = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../semantics");
        for m in MUTANTS {
            let text = std::fs::read_to_string(semantics.join(m.file))
                .unwrap_or_else(|e| panic!("{}: {}: {e}", m.name, m.file));
            assert!(
                text.contains(m.from),
                "{}: its text is not in {}",
                m.name,
                m.file
            );
            assert_ne!(m.from, m.to, "{}", m.name);
        }
        let mut names: Vec<_> = MUTANTS.iter().map(|m| m.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), MUTANTS.len(), "names are unique");
    }
}
