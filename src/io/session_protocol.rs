//! The session protocol: JSON lines between a rig program (motors and
//! data acquisition, or `tdeploy rig`) and `tdeploy session serve`.
//! Version [`PROTOCOL`]; the whole schema, with an example exchange, is in
//! `docs/session.md`.
//!
//! Every message is one JSON object on one line, with a `type`:
//!
//! - to the controller: `measurements` (`step`, `readings`: an object of
//!   sensor id → value or `null`; a sensor left out was not read;
//!   optional `time_unix_s`), `approve` (`step`), `reject` (`step`,
//!   `reason`), `resume` (`note`), `status`;
//! - from the controller: `hello` (`protocol`, `phase`, `motors`,
//!   `sensors`), `command` (`step`, `payout_change_m` in the motors'
//!   order, `motors`, `cleared`, `predicted_gaps_m`), `stopped` (`step`,
//!   `reason`), `ended` (`status`, `words`), `status` (the session's
//!   `status.json`), `error` (`field`, `message`: the message was refused
//!   and the session is unchanged);
//! - to the rig simulator (`tdeploy rig`): `command` as the controller
//!   sends it; from it: `hello`, `measurements` (as above) and `truth`
//!   (what only a simulator knows: the true gaps and the limits broken).
//!
//! Unknown fields are refused (a misspelt field is never ignored).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::log::READING_RANGE;
use super::session_files::{SessionStatus, StepReadings};
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
    },
    /// Ask for the status.
    Status,
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
        }
    }
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
enum RawIn {
    Measurements {
        step: usize,
        readings: BTreeMap<String, Option<f64>>,
        #[serde(default)]
        time_unix_s: Option<f64>,
    },
    Approve {
        step: usize,
    },
    Reject {
        step: usize,
        reason: String,
    },
    Resume {
        #[serde(default)]
        note: String,
    },
    Status,
    Command {
        step: usize,
        payout_change_m: Vec<f64>,
        // What the controller sends beside the command, for the rig to
        // log: accepted and not used.
        #[serde(default, rename = "motors")]
        _motors: Option<Vec<String>>,
        #[serde(default)]
        cleared: Option<bool>,
        #[serde(default, rename = "predicted_gaps_m")]
        _predicted_gaps_m: Option<Vec<f64>>,
    },
}

/// The field a serde message names (`unknown field `x``, `missing field
/// `x``), or `message`.
fn field_of(serde_message: &str) -> String {
    for pattern in ["unknown field `", "missing field `"] {
        if let Some(rest) = serde_message.split(pattern).nth(1) {
            if let Some(name) = rest.split('`').next() {
                return name.to_string();
            }
        }
    }
    if serde_message.contains("unknown variant") || serde_message.contains("missing field `type`") {
        return "type".into();
    }
    "message".into()
}

/// Parses one line of the protocol for the sensor layout `sensors`.
pub fn parse_in_message(line: &str, sensors: &[Sensor]) -> Result<InMessage, ProtocolError> {
    let raw: RawIn = serde_json::from_str(line).map_err(|e| {
        let text = e.to_string();
        ProtocolError {
            field: field_of(&text),
            message: text,
        }
    })?;
    Ok(match raw {
        RawIn::Measurements {
            step,
            readings,
            time_unix_s,
        } => {
            if let Some(t) = time_unix_s {
                if !t.is_finite() || t < 0.0 {
                    return Err(ProtocolError {
                        field: "time_unix_s".into(),
                        message: format!("{t} is not a time (seconds since 1970)"),
                    });
                }
            }
            let mut values = vec![None; sensors.len()];
            for (id, value) in readings {
                let field = format!("readings.{id}");
                let s = sensors
                    .iter()
                    .position(|s| s.id == id)
                    .ok_or_else(|| ProtocolError {
                        field: field.clone(),
                        message: format!("no sensor \"{id}\" in the session's layout"),
                    })?;
                if let Some(v) = value {
                    READING_RANGE.check(v).map_err(|m| ProtocolError {
                        field: field.clone(),
                        message: m,
                    })?;
                }
                values[s] = value;
            }
            InMessage::Measurements(StepReadings { step, values })
        }
        RawIn::Approve { step } => InMessage::Approve { step },
        RawIn::Reject { step, reason } => InMessage::Reject { step, reason },
        RawIn::Resume { note } => InMessage::Resume { note },
        RawIn::Status => InMessage::Status,
        RawIn::Command {
            step,
            payout_change_m,
            cleared,
            ..
        } => {
            if let Some(k) = payout_change_m.iter().position(|u| !u.is_finite()) {
                return Err(ProtocolError {
                    field: format!("payout_change_m[{k}]"),
                    message: "not a finite number".into(),
                });
            }
            InMessage::Command {
                step,
                payout_change_m,
                cleared,
            }
        }
    })
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
