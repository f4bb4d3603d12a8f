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
    let program = v.trace.program();
    let mut listeners: BTreeMap<(Comp, u32), u32> = BTreeMap::new();
    let mut checking: BTreeMap<(Comp, u32), bool> = BTreeMap::new();
    let mut read: BTreeMap<Comp, bool> = BTreeMap::new();
    for i in 0..v.len() {
        match v.obs(i) {
            Obs::Listeners { comp, inst, n } => {
                listeners.insert((comp, inst), n);
                if n == 0 && checking.get(&(comp, inst)) == Some(&true) {
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
                if on && listeners.get(&(comp, inst)).copied().unwrap_or(0) == 0 {
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
                checking.insert((comp, inst), on);
            }
            Obs::Emitted {
                signal, sig, inst, ..
            } if signal.kind == SignalKind::Triggered
                && checking.get(&(signal.comp, inst)) != Some(&true) =>
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
                read.insert(comp, on);
            }
            Obs::Left { comp, instance, .. } => {
                if Some(comp) == program {
                    // the manager went with its program: it reads nothing
                    read.clear();
                }
                listeners.remove(&(comp, instance));
                checking.remove(&(comp, instance));
            }
            _ => {}
        }
    }
    if !f.judged(v.len().saturating_sub(1)) {
        return;
    }
    for e in events {
        let heard = read.get(&e).copied().unwrap_or(false);
        for inst in v.alive_at(e, v.len()) {
            let is = checking.get(&(e, inst)).copied().unwrap_or(false);
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
