//! M codes: classified by modal group, then run in LinuxCNC's order (tool change,
//! spindle, coolant) with the printer codes of FDM programs.

use super::interp::{Fail, Interp, Res};
use crate::error::GcodeErrorKind;
use crate::motion::{Coolant, Motion, MotionSink, SpindleDirection};

/// A block's M codes by modal group.
#[derive(Clone, Copy)]
pub(super) struct MCodes {
    pub(super) spindle: Option<(u16, usize)>,
    pub(super) tool: Option<(u16, usize)>,
    pub(super) stop: Option<(u16, usize)>,
    pub(super) coolant: [Option<Coolant>; 2],
    pub(super) e_mode: Option<u16>,
    pub(super) retract_set: Option<usize>,
}

impl Interp<'_> {
    /// Classifies the block's M codes by modal group and checks conflicts; notes FDM evidence.
    pub(super) fn m_codes<E>(&mut self) -> Res<MCodes, E> {
        let mut m_spindle: Option<(u16, usize)> = None;
        let mut m_tool = None;
        let mut m_stop = None;
        let mut coolant: [Option<Coolant>; 2] = [None, None];
        let mut m_e_mode = None;
        let mut m_retract_set = None;
        for k in 0..self.block.nm {
            let (code, col) = self.block.m[k];
            let col = col as usize;
            let slot = match code {
                3..=5 => &mut m_spindle,
                6 | 61 => &mut m_tool,
                0 | 1 | 2 | 30 | 60 => &mut m_stop,
                7..=9 => {
                    let c = match code {
                        7 => Coolant::Mist,
                        8 => Coolant::Flood,
                        _ => Coolant::Off,
                    };
                    if coolant[0].is_none() {
                        coolant[0] = Some(c);
                    } else {
                        coolant[1] = Some(c);
                    }
                    continue;
                }
                82 | 83 => {
                    self.fdm_evidence();
                    m_e_mode = Some(code);
                    continue;
                }
                207 => {
                    m_retract_set = Some(col);
                    continue;
                }
                104 | 109 | 140 | 190 => {
                    self.fdm_evidence();
                    continue;
                }
                // LinuxCNC: overrides, I/O, spindle orient, modal state save/restore.
                19 | 48..=53 | 62..=68 | 70..=73 => continue,
                // Common printer codes with no motion meaning.
                17
                | 18
                | 84
                | 105
                | 106
                | 107
                | 110
                | 112
                | 114
                | 115
                | 117
                | 80
                | 81
                | 92
                | 201..=206
                | 220
                | 221
                | 400
                | 420
                | 500
                | 501
                | 503
                | 851
                | 900
                    if !self.strict =>
                {
                    continue;
                }
                _ => {
                    let k = GcodeErrorKind::UnknownCode(format!("M{code}"));
                    if self.strict {
                        return Err(Fail::Line(col, k));
                    }
                    self.warn(col, k);
                    continue;
                }
            };
            if let Some((other, _)) = *slot {
                return Err(Fail::Line(
                    col,
                    GcodeErrorKind::ModalConflict(format!(
                        "M{other} and M{code} are in the same modal group"
                    )),
                ));
            }
            *slot = Some((code, col));
        }
        Ok(MCodes {
            spindle: m_spindle,
            tool: m_tool,
            stop: m_stop,
            coolant,
            e_mode: m_e_mode,
            retract_set: m_retract_set,
        })
    }

    /// Tool change (`M6`, `M61`), spindle (`M3`-`M5`, or a new S), coolant (`M7`-`M9`),
    /// extrusion mode (`M82`/`M83`) and firmware-retract length (`M207`).
    pub(super) fn m_actions<S: MotionSink>(
        &mut self,
        m: &MCodes,
        spindle_changed: bool,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let MCodes {
            spindle: m_spindle,
            tool: m_tool,
            coolant,
            e_mode: m_e_mode,
            retract_set: m_retract_set,
            ..
        } = *m;
        if let Some((code, col)) = m_tool {
            if code == 6 && self.comp.side.is_some() {
                return Err(super::comp::comp_refused(
                    col,
                    "cannot change tools with cutter radius compensation on",
                ));
            }
            let tool = if code == 61 {
                match self.block.get(b'q') {
                    Some(q) if q >= 0.0 && q.fract() == 0.0 && q <= u32::MAX as f64 => Some(q as u32),
                    _ => {
                        return Err(Fail::Line(
                            col,
                            GcodeErrorKind::MissingWord { code: "M61".into(), letter: 'Q' },
                        ));
                    }
                }
            } else {
                self.tool
            };
            if let Some(tool) = tool {
                if code == 6
                    && let Some(at) = self.comp.tool_at.take()
                {
                    // LinuxCNC re-reads the position after a tool change: where G40 left
                    // the tool, not the programmed point.
                    self.set_work(at);
                }
                self.tool = Some(tool);
                self.spindle_tool = tool;
                self.emit(sink, &Motion::ToolChange { tool })?;
            } else {
                self.lenient(col, GcodeErrorKind::MissingWord { code: "M6".into(), letter: 'T' })?;
            }
        }
        if let Some((code, _)) = m_spindle {
            self.spindle = match code {
                3 => SpindleDirection::Clockwise,
                4 => SpindleDirection::CounterClockwise,
                _ => SpindleDirection::Off,
            };
            self.emit(sink, &Motion::Spindle { rpm: self.rpm, direction: self.spindle })?;
        } else if spindle_changed && self.spindle != SpindleDirection::Off {
            self.emit(sink, &Motion::Spindle { rpm: self.rpm, direction: self.spindle })?;
        }
        for c in coolant.into_iter().flatten() {
            self.emit(sink, &Motion::Coolant(c))?;
        }
        if let Some(code) = m_e_mode {
            self.e_relative = code == 83;
            self.e_axis = true;
        }
        if let Some(col) = m_retract_set
            && let Some(s) = self.block.get(b's')
        {
            if s < 0.0 {
                return Err(Fail::Line(col, GcodeErrorKind::BadValue("negative retract length".into())));
            }
            self.retract_len = s;
        }
        Ok(())
    }
}
