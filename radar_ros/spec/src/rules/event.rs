//! The event rule (E1), judged from what each event instance knew of its listeners and what the manager read.

use std::collections::BTreeMap;

use super::*;
use crate::trace::{Obs, Role, Signal, SignalKind};

pub(super) fn check(f: &mut Found<'_, '_>) {
    let v = f.view;
    let events: Vec<Comp> = v
        .trace
        .components
        .iter()
        .enumerate()
        .filter(|(_, c)| c.role == Role::Event)
        .map(|(i, _)| Comp(i as u16))
        .collect();
    let mut known = Known::default();
    for i in 0..v.len() {
        known.read(f, i);
    }
    if !f.judged(v.len().saturating_sub(1)) {
        return;
    }
    for e in events {
        known.judge_the_end(f, e);
    }
}

/// What the records up to one point say of each event instance's listeners and checking, and of whether the
/// manager reads each event's `triggered`.
#[derive(Default)]
struct Known {
    listeners: BTreeMap<(Comp, u32), u32>,
    checking: BTreeMap<(Comp, u32), bool>,
    read: BTreeMap<Comp, bool>,
}

impl Known {
    /// Takes in record `i`, adding what it breaks of E1 as it happens.
    fn read(&mut self, f: &mut Found<'_, '_>, i: usize) {
        let v = f.view;
        match v.obs(i) {
            Obs::Listeners { comp, inst, n } => {
                self.listeners.insert((comp, inst), n);
                if n == 0 && self.checking.get(&(comp, inst)) == Some(&true) {
                    let stops = v.step_of(i).any(|j| {
                        j > i
                            && matches!(
                                v.obs(j),
                                Obs::Checking { comp: c, inst: k, on: false } if (c, k) == (comp, inst)
                            )
                    });
                    if !stops {
                        let name = f.name(comp).to_owned();
                        f.add(
                            &E1_CHECKS_ONLY_WHILE_LISTENED,
                            i,
                            &[comp],
                            &[],
                            &[],
                            format!("{name} learned it has no listener and went on checking"),
                        );
                    }
                }
            }
            Obs::Checking { comp, inst, on } => {
                if on && self.listeners.get(&(comp, inst)).copied().unwrap_or(0) == 0 {
                    let name = f.name(comp).to_owned();
                    f.add(
                        &E1_CHECKS_ONLY_WHILE_LISTENED,
                        i,
                        &[comp],
                        &[],
                        &[],
                        format!("{name} began checking with no listener it knows of"),
                    );
                }
                self.checking.insert((comp, inst), on);
            }
            Obs::Emitted {
                signal, sig, inst, ..
            } if signal.kind == SignalKind::Triggered
                && self.checking.get(&(signal.comp, inst)) != Some(&true) =>
            {
                let name = f.name(signal.comp).to_owned();
                f.add(
                    &E1_CHECKS_ONLY_WHILE_LISTENED,
                    i,
                    &[signal.comp],
                    &[],
                    &[sig],
                    format!("{name} emitted `triggered` while not checking"),
                );
            }
            Obs::Reading {
                signal:
                    Signal {
                        comp,
                        kind: SignalKind::Triggered,
                    },
                on,
            } => {
                self.read.insert(comp, on);
            }
            Obs::Left { comp, instance, .. } => {
                if Some(comp) == v.trace.program() {
                    // the manager went with its program: it reads nothing
                    self.read.clear();
                }
                self.listeners.remove(&(comp, instance));
                self.checking.remove(&(comp, instance));
            }
            _ => {}
        }
    }

    /// At the end of the trace, each live instance of event `e` checks exactly when its `triggered` is read.
    fn judge_the_end(&self, f: &mut Found<'_, '_>, e: Comp) {
        let v = f.view;
        let heard = self.read.get(&e).copied().unwrap_or(false);
        for inst in v.alive_at(e, v.len()) {
            let is = self.checking.get(&(e, inst)).copied().unwrap_or(false);
            if is == heard || v.stopping_before((e, inst), v.len()) {
                continue;
            }
            let name = f.name(e).to_owned();
            f.add(
                &E1_UNHEARD_EVENTS_STOP,
                v.len().saturating_sub(1),
                &[e],
                &[],
                &[],
                if is {
                    format!("in the end {name} (instance {inst}) checks though nothing reads its `triggered`")
                } else {
                    format!("in the end {name} (instance {inst}) does not check though its `triggered` is read")
                },
            );
        }
    }
}
