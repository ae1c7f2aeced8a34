//! A parser for Tony Cassandra's `.pomdp` text format (as read by
//! pomdp-solve, and used for the classic POMDP benchmark files).
//!
//! ```
//! let text = "discount: 0.9 values: reward states: 2 actions: 1 observations: 1
//!             T: 0 identity O: 0 uniform R: 0 : 1 : * : * 1.0";
//! let pomdp = ceworld::world::cassandra::parse(text, &ceworld::world::cassandra::Options::default()).unwrap();
//! assert_eq!(pomdp.expected_reward(), vec![0.0, 1.0]);
//! ```
//!
//! # What is accepted
//!
//! * Preamble, in any order, before the first `T:`/`O:`/`R:` entry, each
//!   line at most once: `discount:` (0..=1; optional), `values: reward|cost`
//!   (`rewards`/`costs` too; default reward), and `states:`, `actions:`,
//!   `observations:` as a count or a list of names (required).
//! * `start:` after `states:`, before any entry: S probabilities,
//!   `uniform`, a state name, a single state index, or `start include:` /
//!   `start exclude:` with a list of states (uniform over those / the others).
//! * `T: a : s : s' p`, `T: a : s` + S numbers | `uniform` | `reset` (the
//!   start belief), `T: a` + S×S numbers | `uniform` | `identity`.
//! * `O: a : s' : o p`, `O: a : s'` + O numbers | `uniform`, `O: a` + S×O
//!   numbers | `uniform`.
//! * `R: a : s : s' : o v`, `R: a : s : s'` + O numbers, `R: a : s` + S×O.
//! * Every `a`, `s`, `s'`, `o` is a name, a 0-based index or `*`. Later
//!   entries override earlier ones. `#` comments run to the end of a line;
//!   other whitespace, line breaks included, only separates tokens. Numbers
//!   may carry a sign, attached or as a separate token (`- 2`).
//! * Names: an ASCII letter or `_`, then letters, digits, `_`, `-` or `.`.
//!   The statement keywords (`discount values states actions observations
//!   start T O R`) are reserved; `uniform`, `identity`, `reset` are not.
//!
//! After parsing, every `T` row, every `O` row and the start belief must
//! sum to 1 within [`Options::tolerance`]; rows off by more than rounding
//! noise are renormalised and listed in [`Pomdp::renormalised`].

mod entries;
mod error;
mod lexer;
mod model;
mod parse;
mod preamble;
mod reward;
pub(crate) mod validate;

pub use error::ParseError;
pub use model::{Options, Pomdp, RewardEntry, Values};
pub use parse::{MAX_FILE_BYTES, parse, parse_bytes, parse_file};
