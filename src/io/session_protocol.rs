//! The session protocol: JSON lines between a rig program (motors and
//! data acquisition, or `tdeploy rig`) and `tdeploy session serve`.
//! Version [`PROTOCOL`]; the whole schema, with an example exchange, is in
//! `docs/session.md`.
//!
//! Every message is one JSON object on one line, with a `type`:
//!
//! - to the controller: `measurements` (`step`, `readings`: an object of
//!   sensor id → value or `null`; a sensor left out was not read),
//!   `approve` (`step`), `reject` (`step`,
//!   `reason`), `resume` (`note`, `discard`), `status`;
//! - from the controller: `hello` (`protocol`, `phase`, `motors`,
//!   `sensors`), `command` (`step`, `payout_change_m` in the motors'
//!   order, `motors`, `cleared`, `predicted_gaps_m`), `read_again`
//!   (`step`, `reason`: discarded readings to take again, no command
//!   repeated), `stopped` (`step`,
//!   `reason`), `ended` (`status`, `words`), `status` (the session's
//!   `status.json`), `error` (`field`, `message`: the message was refused
//!   and the session is unchanged);
//! - to the rig simulator (`tdeploy rig`): `command` and `read_again` as
//!   the controller sends them; from it: `hello`, `measurements` (as above) and `truth`
//!   (what only a simulator knows: the true gaps and the limits broken).
//!
//! Unknown fields, and a key given twice, are refused (a misspelt field
//! is never ignored, and never shadows another); a refusal names the
//! field (`readings.load_A_cc0`, `step`, …).

use std::collections::BTreeMap;

use serde::Serialize;
use serde_json::{Map, Value};

use super::log::READING_RANGE;
use crate::control::{Session, SessionPhase, StepReadings};
use crate::sim::Sensor;

/// The protocol's name and version, sent in every `hello`.
pub const PROTOCOL: &str = "tensegrity-deploy/session-protocol/1";

/// A message refused: the field at fault (`message` for the whole line)
/// and why.
#[derive(Debug, Clone, PartialEq)]
pub struct ProtocolError {
    /// The field at fault, e.g. `readings.load_A_cc0`, `step`, `type`.
    pub field: String,
    /// What is wrong.
    pub message: String,
    /// Line and column of a JSON syntax error (`None` for a message
    /// that parses but is refused).
    pub position: Option<(usize, usize)>,
}

impl ProtocolError {
    /// A refusal of `field`.
    pub fn field(field: &str, message: String) -> Self {
        ProtocolError {
            field: field.to_string(),
            message,
            position: None,
        }
    }
}

impl std::fmt::Display for ProtocolError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "field `{}`: {}", self.field, self.message)
    }
}

/// A message to the controller or to the rig, parsed and checked.
#[derive(Debug, Clone, PartialEq)]
pub enum InMessage {
    /// Readings of one step.
    Measurements(StepReadings),
    /// Approve the pending command `step`.
    Approve {
        /// The command.
        step: usize,
    },
    /// Reject the pending command `step`.
    Reject {
        /// The command.
        step: usize,
        /// Why.
        reason: String,
    },
    /// Resume a stopped session.
    Resume {
        /// The operator's note.
        note: String,
        /// Discard the readings that tripped the interlock.
        discard: bool,
    },
    /// Ask for the status.
    Status,
    /// Read the sensors again for `step` (to the rig; the command is
    /// not repeated).
    ReadAgain {
        /// The step.
        step: usize,
    },
    /// A command (to the rig).
    Command {
        /// The command's number.
        step: usize,
        /// Payout change per motor, m.
        payout_change_m: Vec<f64>,
        /// Whether it may be executed (`None`: not said, as a rig
        /// program's own command; `Some(false)`: it awaits approval).
        cleared: Option<bool>,
    },
}

impl InMessage {
    /// The message's `type`.
    pub fn type_name(&self) -> &'static str {
        match self {
            InMessage::Measurements(_) => "measurements",
            InMessage::Approve { .. } => "approve",
            InMessage::Reject { .. } => "reject",
            InMessage::Resume { .. } => "resume",
            InMessage::Status => "status",
            InMessage::Command { .. } => "command",
            InMessage::ReadAgain { .. } => "read_again",
        }
    }
}

/// The fields each message type may have (`type` aside), and whether
/// each is required.
fn fields_of(kind: &str) -> Option<&'static [(&'static str, bool)]> {
    Some(match kind {
        "measurements" => &[("step", true), ("readings", true)],
        "approve" => &[("step", true)],
        "reject" => &[("step", true), ("reason", true)],
        "resume" => &[("note", false), ("discard", false)],
        "status" => &[],
        "read_again" => &[("step", true), ("reason", false)],
        // What the controller sends beside the command (`motors`,
        // `predicted_gaps_m`) is accepted for the rig to log.
        "command" => &[
            ("step", true),
            ("payout_change_m", true),
            ("cleared", false),
            ("motors", false),
            ("predicted_gaps_m", false),
        ],
        _ => return None,
    })
}

/// An object that refuses a key given twice (`serde_json::Value` keeps
/// the last silently).
struct UniqueKeys(Map<String, Value>);

impl<'de> serde::Deserialize<'de> for UniqueKeys {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = UniqueKeys;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a JSON object")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut access: A,
            ) -> Result<UniqueKeys, A::Error> {
                let mut map = Map::new();
                while let Some((key, value)) = access.next_entry::<String, UniqueValue>()? {
                    if map.contains_key(&key) {
                        return Err(serde::de::Error::custom(format!("duplicate key `{key}`")));
                    }
                    map.insert(key, value.0);
                }
                Ok(UniqueKeys(map))
            }
        }
        d.deserialize_map(Visitor)
    }
}

/// A value whose objects, at any depth, refuse a key given twice.
struct UniqueValue(Value);

impl<'de> serde::Deserialize<'de> for UniqueValue {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = UniqueValue;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a JSON value")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                a: A,
            ) -> Result<UniqueValue, A::Error> {
                let UniqueKeys(map) = serde::Deserialize::deserialize(
                    serde::de::value::MapAccessDeserializer::new(a),
                )?;
                Ok(UniqueValue(Value::Object(map)))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut a: A,
            ) -> Result<UniqueValue, A::Error> {
                let mut items = Vec::new();
                while let Some(UniqueValue(v)) = a.next_element()? {
                    items.push(v);
                }
                Ok(UniqueValue(Value::Array(items)))
            }
            fn visit_bool<E>(self, v: bool) -> Result<UniqueValue, E> {
                Ok(UniqueValue(Value::Bool(v)))
            }
            fn visit_i64<E>(self, v: i64) -> Result<UniqueValue, E> {
                Ok(UniqueValue(Value::from(v)))
            }
            fn visit_u64<E>(self, v: u64) -> Result<UniqueValue, E> {
                Ok(UniqueValue(Value::from(v)))
            }
            fn visit_f64<E>(self, v: f64) -> Result<UniqueValue, E> {
                Ok(UniqueValue(Value::from(v)))
            }
            fn visit_str<E>(self, v: &str) -> Result<UniqueValue, E> {
                Ok(UniqueValue(Value::String(v.to_string())))
            }
            fn visit_string<E>(self, v: String) -> Result<UniqueValue, E> {
                Ok(UniqueValue(Value::String(v)))
            }
            fn visit_unit<E>(self) -> Result<UniqueValue, E> {
                Ok(UniqueValue(Value::Null))
            }
            fn visit_none<E>(self) -> Result<UniqueValue, E> {
                Ok(UniqueValue(Value::Null))
            }
        }
        d.deserialize_any(Visitor)
    }
}

fn step_of(m: &Map<String, Value>) -> Result<usize, ProtocolError> {
    m.get("step")
        .and_then(Value::as_u64)
        .map(|k| k as usize)
        .ok_or_else(|| ProtocolError::field("step", "must be a non-negative integer".into()))
}

fn text_of(m: &Map<String, Value>, field: &str) -> Result<String, ProtocolError> {
    match m.get(field) {
        None => Ok(String::new()),
        Some(Value::String(t)) => Ok(t.clone()),
        Some(_) => Err(ProtocolError::field(field, "must be a string".into())),
    }
}

/// Parses one message of the protocol (one line, or a file holding one
/// JSON object) for the sensor layout `sensors`.
pub fn parse_in_message(text: &str, sensors: &[Sensor]) -> Result<InMessage, ProtocolError> {
    let UniqueKeys(m) = serde_json::from_str(text).map_err(|e| {
        let position = (e.line() > 0).then(|| (e.line(), e.column()));
        let field = match e.to_string().split("duplicate key `").nth(1) {
            Some(rest) => rest.split('`').next().unwrap_or("message").to_string(),
            None => "message".into(),
        };
        ProtocolError {
            field,
            message: format!("not a message (one JSON object): {e}"),
            position,
        }
    })?;
    let kind = match m.get("type") {
        Some(Value::String(t)) => t.clone(),
        _ => {
            return Err(ProtocolError::field(
                "type",
                "missing, or not a string".into(),
            ))
        }
    };
    let Some(fields) = fields_of(&kind) else {
        return Err(ProtocolError::field(
            "type",
            format!("unknown message type \"{kind}\" (measurements, approve, reject, resume, status, command, read_again)"),
        ));
    };
    for key in m.keys().filter(|k| *k != "type") {
        if !fields.iter().any(|(f, _)| f == key) {
            return Err(ProtocolError::field(
                key,
                format!("not a field of a \"{kind}\" message"),
            ));
        }
    }
    for (f, required) in fields {
        if *required && !m.contains_key(*f) {
            return Err(ProtocolError::field(f, "missing".into()));
        }
    }
    Ok(match kind.as_str() {
        "measurements" => {
            let step = step_of(&m)?;
            let Some(Value::Object(readings)) = m.get("readings") else {
                return Err(ProtocolError::field(
                    "readings",
                    "must be an object of sensor id → number or null".into(),
                ));
            };
            let mut values = vec![None; sensors.len()];
            for (id, value) in readings {
                let field = format!("readings.{id}");
                let s = sensors.iter().position(|s| &s.id == id).ok_or_else(|| {
                    ProtocolError::field(
                        &field,
                        format!("no sensor \"{id}\" in the session's layout"),
                    )
                })?;
                values[s] = match value {
                    Value::Null => None,
                    Value::Number(n) => {
                        let v = n.as_f64().unwrap_or(f64::NAN);
                        READING_RANGE
                            .check(v)
                            .map_err(|why| ProtocolError::field(&field, why))?;
                        Some(v)
                    }
                    _ => {
                        return Err(ProtocolError::field(
                            &field,
                            "must be a number or null".into(),
                        ))
                    }
                };
            }
            InMessage::Measurements(StepReadings { step, values })
        }
        "approve" => InMessage::Approve { step: step_of(&m)? },
        "reject" => InMessage::Reject {
            step: step_of(&m)?,
            reason: text_of(&m, "reason")?,
        },
        "resume" => InMessage::Resume {
            note: text_of(&m, "note")?,
            discard: match m.get("discard") {
                None => false,
                Some(Value::Bool(b)) => *b,
                Some(_) => {
                    return Err(ProtocolError::field(
                        "discard",
                        "must be true or false".into(),
                    ))
                }
            },
        },
        "status" => InMessage::Status,
        "read_again" => InMessage::ReadAgain { step: step_of(&m)? },
        _ => {
            let step = step_of(&m)?;
            let Some(Value::Array(items)) = m.get("payout_change_m") else {
                return Err(ProtocolError::field(
                    "payout_change_m",
                    "must be a list of numbers, m".into(),
                ));
            };
            let mut payout_change_m = Vec::with_capacity(items.len());
            for (k, v) in items.iter().enumerate() {
                match v.as_f64().filter(|v| v.is_finite()) {
                    Some(v) => payout_change_m.push(v),
                    None => {
                        return Err(ProtocolError::field(
                            &format!("payout_change_m[{k}]"),
                            "not a finite number".into(),
                        ))
                    }
                }
            }
            let cleared = match m.get("cleared") {
                None => None,
                Some(Value::Bool(b)) => Some(*b),
                Some(_) => {
                    return Err(ProtocolError::field(
                        "cleared",
                        "must be true or false".into(),
                    ))
                }
            };
            InMessage::Command {
                step,
                payout_change_m,
                cleared,
            }
        }
    })
}

/// Where a session stands, as `status.json` and the protocol's status
/// message write it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SessionStatus {
    /// The phase ([`SessionPhase::label`]).
    pub phase: &'static str,
    /// The last step measured (`None`: not even the start).
    pub last_measured_step: Option<usize>,
    /// The pending command's number and payout change per motor, m.
    pub pending_step: Option<usize>,
    /// Payout change per motor of the pending command, m.
    pub pending_command_m: Option<Vec<f64>>,
    /// Whether the pending command may be executed (approved, or no
    /// approval required).
    pub pending_cleared: Option<bool>,
    /// Gap per midspan pair the controller predicts for the pending
    /// command, m.
    pub pending_predicted_gaps_m: Option<Vec<f64>>,
    /// Commands executed and measured.
    pub commands_executed: usize,
    /// Largest measured gap at the last step, m.
    pub last_largest_measured_gap_m: Option<f64>,
    /// The payout scale of each bridge half as estimated now, 1.
    pub estimated_payout_scale: Vec<f64>,
    /// The load cells' common bias as estimated now: mean and SD, N.
    pub estimated_load_cell_bias_n: Option<(f64, f64)>,
    /// Why the session is stopped, if it is.
    pub stopped_reason: Option<String>,
    /// How it ended (status label), if it has.
    pub ended_status: Option<String>,
    /// How it ended, in words.
    pub ended_words: Option<String>,
    /// Commands whose issued value this version would not issue on replay
    /// (a journal written by another version); empty normally.
    pub diverged_commands: Vec<usize>,
    /// Events in the journal.
    pub events: usize,
}

impl SessionStatus {
    /// The status of `session`; `predicted_gaps_m` are the pending
    /// command's predicted gaps where known.
    pub fn of(session: &Session, predicted_gaps_m: Option<Vec<f64>>) -> Self {
        let phase = session.phase();
        let (pending_step, pending_command_m, pending_cleared) = match phase {
            SessionPhase::Pending {
                step,
                command_m,
                cleared,
            } => (Some(*step), Some(command_m.clone()), Some(*cleared)),
            _ => (None, None, None),
        };
        let controller = session.controller();
        let structure = session.setup().model.structure();
        let last_gap = session.readings().last().and_then(|r| {
            crate::control::measured_gap_vectors(structure, session.setup().sensors, r)
                .iter()
                .flatten()
                .map(|g| g.norm())
                .reduce(f64::max)
        });
        SessionStatus {
            phase: phase.label(),
            last_measured_step: session.readings().len().checked_sub(1),
            pending_predicted_gaps_m: pending_step.and(predicted_gaps_m),
            pending_step,
            pending_command_m,
            pending_cleared,
            commands_executed: session.executed_commands_m().len(),
            last_largest_measured_gap_m: last_gap,
            estimated_payout_scale: controller.map_or_else(Vec::new, |c| c.part_payout_scale()),
            estimated_load_cell_bias_n: controller.and_then(|c| c.load_cell_bias_n()),
            stopped_reason: match phase {
                SessionPhase::Stopped { reason, .. } => Some(reason.clone()),
                _ => None,
            },
            ended_status: match phase {
                SessionPhase::Ended { status, .. } => Some(status.clone()),
                _ => None,
            },
            ended_words: match phase {
                SessionPhase::Ended { words, .. } => Some(words.clone()),
                _ => None,
            },
            diverged_commands: session.diverged_commands().to_vec(),
            events: session.event_count(),
        }
    }
}

/// A message from the controller or the rig.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum OutMessage<'a> {
    /// The first message: who speaks and where the session stands.
    Hello {
        /// [`PROTOCOL`].
        protocol: &'static str,
        /// Who: `session` or `rig`.
        role: &'static str,
        /// The phase (sessions only).
        #[serde(skip_serializing_if = "Option::is_none")]
        phase: Option<&'static str>,
        /// The motors (continuous cables) in the commands' order.
        motors: Vec<&'a str>,
        /// The sensors, in the layout's order.
        sensors: Vec<&'a str>,
    },
    /// A command to execute.
    Command {
        /// The command's number.
        step: usize,
        /// Payout change per motor, m.
        payout_change_m: &'a [f64],
        /// The motors, in order.
        motors: Vec<&'a str>,
        /// Whether it may be executed now (approved, or no approval
        /// required); `false`: send `approve` or `reject` first.
        cleared: bool,
        /// Gap per pair the controller predicts for it, m.
        predicted_gaps_m: Option<&'a [f64]>,
    },
    /// Readings of one step (from the rig).
    Measurements {
        /// The step.
        step: usize,
        /// Sensor id → value (`null`: not read).
        readings: BTreeMap<&'a str, Option<f64>>,
    },
    /// What only a simulator knows, after a command (from the rig).
    Truth {
        /// The step.
        step: usize,
        /// True gap per midspan pair, m.
        true_gaps_m: &'a [f64],
        /// The truth's limits broken along the command, in words.
        violations: Vec<String>,
    },
    /// Read the sensors again for `step` and send its readings: the
    /// readings sent were discarded (no command is repeated).
    ReadAgain {
        /// The step.
        step: usize,
        /// Why, in words.
        reason: &'a str,
    },
    /// An interlock stopped the session.
    Stopped {
        /// The step whose readings tripped it.
        step: usize,
        /// What tripped.
        reason: &'a str,
    },
    /// The session ended.
    Ended {
        /// The status label.
        status: &'a str,
        /// In words.
        words: &'a str,
    },
    /// The session's status.
    Status {
        /// As `status.json`.
        status: &'a SessionStatus,
    },
    /// A message refused; the session is unchanged.
    Error {
        /// The field at fault.
        field: &'a str,
        /// Why.
        message: &'a str,
    },
}

impl OutMessage<'_> {
    /// The message as one line (no line break).
    pub fn line(&self) -> String {
        // Every field is a plain number, string or list: serialising
        // cannot fail.
        serde_json::to_string(self).unwrap_or_else(|e| {
            format!("{{\"type\":\"error\",\"field\":\"message\",\"message\":\"{e}\"}}")
        })
    }
}
