//! The categorical laws controllers are drawn from (model §8): their start (uniform, or a
//! memory template), draws, refits and escapes.
//!
//! The memory is either `n` flat nodes (one successor law per node and observation: `n²·Y`
//! probabilities) or `m` registers of `d` values (`n = d^m` nodes, a node the digits of its
//! registers in base `d`): register `i` moves from `b` to `f_i(y, a, b)`, `a` the value of
//! register `i − 1` (cyclically), one law per (register, observation, `a`, `b`), `m·Y·d³`
//! probabilities. A shift register (`f_1 = y`, `f_i = a`) holds the last `m` observations.

use rand::RngExt;

use crate::ce::controller::config::Template;
use crate::policy::controller::Controller;

/// The categorical laws the controllers are drawn from.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Laws {
    n: usize,
    n_actions: usize,
    y1: usize,
    /// Whether the controllers are Mealy machines: a decision law per node and observation.
    #[serde(default)]
    mealy: bool,
    /// `act[r·A + a]`, `r` the node (Moore) or `q·(|O|+1) + y` (Mealy).
    act: Vec<f64>,
    /// Flat nodes: `next[(q·(|O|+1) + y)·n + q']`. Registers: `next[row·d + b']`, `row =
    /// ((i·(|O|+1) + y)·d + a)·d + b` (module docs).
    next: Vec<f64>,
    /// Registers of the memory (0: flat nodes).
    #[serde(default)]
    registers: usize,
}

impl Laws {
    pub(super) fn uniform(n: usize, n_actions: usize, y1: usize, mealy: bool) -> Laws {
        Laws::uniform_registers(n, n_actions, y1, mealy, 0)
    }

    /// The uniform laws of `n` nodes held in `registers` registers (0: flat nodes; else `n`
    /// is `d^registers`).
    fn uniform_registers(n: usize, n_actions: usize, y1: usize, mealy: bool, registers: usize) -> Laws {
        let mut laws = Laws::zero(n, n_actions, y1, mealy, registers);
        laws.act.fill(1.0 / n_actions as f64);
        let width = laws.width();
        laws.next.fill(1.0 / width as f64);
        laws
    }

    /// Laws of that shape with every probability 0, for one-hot laws to be set on.
    fn zero(n: usize, n_actions: usize, y1: usize, mealy: bool, registers: usize) -> Laws {
        let rows = if mealy { n * y1 } else { n };
        let next = if registers == 0 {
            n * y1 * n
        } else {
            let d = register_size(n, registers);
            registers * y1 * d * d * d
        };
        Laws { n, n_actions, y1, mealy, act: vec![0.0; rows * n_actions], next: vec![0.0; next], registers }
    }

    /// The values of one register (`n` with flat nodes): the length of a successor law.
    fn width(&self) -> usize {
        if self.registers == 0 { self.n } else { register_size(self.n, self.registers) }
    }

    /// The successor of node `q` after `y` where register `i` moves by `f[row]` (module docs).
    fn compose(&self, f: &[u32]) -> Vec<u32> {
        let (m, d, y1) = (self.registers, self.width(), self.y1);
        let mut next = vec![0; self.n * y1];
        for q in 0..self.n {
            for y in 0..y1 {
                let mut to = 0;
                let mut power = 1;
                for i in 0..m {
                    let (a, b) = (digit(q, (i + m - 1) % m, d), digit(q, i, d));
                    to += f[((i * y1 + y) * d + a) * d + b] as usize * power;
                    power *= d;
                }
                next[q * y1 + y] = to as u32;
            }
        }
        next
    }

    /// The uniform laws of `n` nodes (in `registers` registers, 0: flat) with `weight` of each
    /// successor law moved onto `template`'s successors.
    pub(super) fn start(
        n: usize,
        n_actions: usize,
        y1: usize,
        mealy: bool,
        registers: usize,
        template: Template,
        weight: f64,
    ) -> Laws {
        let mut laws = Laws::uniform_registers(n, n_actions, y1, mealy, registers);
        let width = laws.width();
        for (r, row) in laws.next.chunks_mut(width).enumerate() {
            let targets = if registers == 0 {
                template.successors(r / y1, r % y1, n, y1)
            } else {
                let (i, y, a, b) = register_row(r, y1, width);
                template.register_successors(i, y, a, b, width)
            };
            if targets.is_empty() {
                continue;
            }
            for p in row.iter_mut() {
                *p *= 1.0 - weight;
            }
            for &to in &targets {
                row[to] += weight / targets.len() as f64;
            }
        }
        laws
    }

    /// Nodes of the controllers drawn.
    pub(super) fn nodes(&self) -> usize {
        self.n
    }

    /// Whether the memory is in registers.
    pub(super) fn factored(&self) -> bool {
        self.registers > 0
    }

    /// Decisions and observations of the controllers drawn.
    pub(super) fn shape(&self) -> (usize, usize) {
        (self.n_actions, self.y1)
    }

    pub(super) fn draw(&self, rng: &mut crate::rng::EngineRng) -> Controller {
        let act = self.act.chunks(self.n_actions).map(|row| pick(row, rng.random())).collect();
        let next: Vec<u32> = self.next.chunks(self.width()).map(|row| pick(row, rng.random())).collect();
        let next = if self.registers == 0 { next } else { self.compose(&next) };
        if self.mealy { Controller::mealy(act, next, self.y1) } else { Controller::moore(act, next) }
    }

    /// `p := α·frequency + (1 − α)·p` over the elite; a decision row with a `best` decision
    /// (credit within episodes, model §8) moves its `α` onto that decision instead.
    pub(super) fn refit(&mut self, elite: &[&Controller], best: Option<&[Option<u32>]>, alpha: f64) {
        let weight = alpha / elite.len() as f64;
        let credited = |r: usize| best.and_then(|b| b[r]);
        for p in self.act.iter_mut().chain(self.next.iter_mut()) {
            *p *= 1.0 - alpha;
        }
        for (r, row) in self.act.chunks_mut(self.n_actions).enumerate() {
            if let Some(a) = credited(r) {
                row[a as usize] += alpha;
            }
        }
        for c in elite {
            for (r, &a) in c.decisions().iter().enumerate() {
                if credited(r).is_none() {
                    self.act[r * self.n_actions + a as usize] += weight;
                }
            }
            if self.registers == 0 {
                for (row, &q2) in c.next.iter().enumerate() {
                    self.next[row * self.n + q2 as usize] += weight;
                }
                continue;
            }
            // Register i's move read where the other registers are 0 (the same everywhere in
            // a controller these laws drew).
            let (m, d, y1) = (self.registers, self.width(), self.y1);
            for (row, law) in self.next.chunks_mut(d).enumerate() {
                let (i, y, a, b) = register_row(row, y1, d);
                let q = b * d.pow(i as u32) + a * d.pow(((i + m - 1) % m) as u32);
                law[digit(c.next[q * y1 + y] as usize, i, d)] += weight;
            }
        }
    }

    /// Mean over rows of the largest probability.
    pub(super) fn concentration(&self) -> f64 {
        let rows = self.act.chunks(self.n_actions).chain(self.next.chunks(self.width()));
        let count = self.act.len() / self.n_actions + self.next.len() / self.width();
        rows.map(|r| r.iter().copied().fold(0.0, f64::max)).sum::<f64>() / count as f64
    }
}

/// The value of each of `registers` registers of `n = d^registers` nodes.
pub(super) fn register_size(n: usize, registers: usize) -> usize {
    let d = (n as f64).powf(1.0 / registers as f64).round() as usize;
    debug_assert_eq!(d.pow(registers as u32), n, "{n} nodes are not {registers} registers");
    d
}

/// The (register `i`, observation `y`, value `a` of register `i − 1`, value `b` of register
/// `i`) of a register's successor law, numbered `((i·Y + y)·d + a)·d + b`.
fn register_row(row: usize, y1: usize, d: usize) -> (usize, usize, usize, usize) {
    (row / (d * d * y1), row / (d * d) % y1, row / d % d, row % d)
}

/// Digit `i` of `q` in base `d`.
fn digit(q: usize, i: usize, d: usize) -> usize {
    q / d.pow(i as u32) % d
}

/// The index drawn from `row` by the uniform number `u` (the last positive entry if rounding
/// leaves `u` past the total).
fn pick(row: &[f64], u: f64) -> u32 {
    let mut acc = 0.0;
    let mut last = 0;
    for (i, &p) in row.iter().enumerate() {
        if p > 0.0 {
            acc += p;
            last = i;
            if u < acc {
                return i as u32;
            }
        }
    }
    last as u32
}

impl Laws {
    /// Laws one node larger than `best`, around it (an escape by growth): every law is the
    /// one-hot law of `best`'s choice, with a new node `n` that copies the node `k` that `best`
    /// enters most (its decision and successors), every move into `k` split evenly between `k`
    /// and its copy; then `weight` of the uniform law is mixed in ([`Laws::inject`]). With
    /// `weight = 0` every controller drawn behaves as `best` does.
    pub(super) fn grown(best: &Controller, n_actions: usize, y1: usize, weight: f64) -> Laws {
        let n = best.nodes();
        let mut entered = vec![0usize; n];
        for &q in &best.next {
            entered[q as usize] += 1;
        }
        // The most entered node, the first of equals.
        let k = (0..n).fold(0, |b, q| if entered[q] > entered[b] { q } else { b });
        let n1 = n + 1;
        let mut laws = Laws::zero(n1, n_actions, y1, best.is_mealy(), 0);
        for q in 0..n1 {
            let from = if q == n { k } else { q };
            if best.is_mealy() {
                for y in 0..y1 {
                    laws.act[(q * y1 + y) * n_actions + best.on[from * y1 + y] as usize] = 1.0;
                }
            } else {
                laws.act[q * n_actions + best.act[from] as usize] = 1.0;
            }
            for y in 0..y1 {
                let to = best.next[from * y1 + y] as usize;
                let row = &mut laws.next[(q * y1 + y) * n1..(q * y1 + y + 1) * n1];
                if to == k {
                    row[k] = 0.5;
                    row[n] = 0.5;
                } else {
                    row[to] = 1.0;
                }
            }
        }
        laws.inject(weight);
        laws
    }

    /// The laws around `c` (a model start): each law is `c`'s choice with `weight`, the
    /// uniform law with the rest.
    pub(super) fn around(c: &Controller, n_actions: usize, y1: usize, weight: f64) -> Laws {
        let mut laws = Laws::zero(c.nodes(), n_actions, y1, c.is_mealy(), 0);
        for (r, &a) in c.decisions().iter().enumerate() {
            laws.act[r * n_actions + a as usize] = 1.0;
        }
        let n = c.nodes();
        for (row, &to) in c.next.iter().enumerate() {
            laws.next[row * n + to as usize] = 1.0;
        }
        laws.inject(1.0 - weight);
        laws
    }

    /// The laws of `n` nodes (in `registers` registers, 0: flat) around the memoryless policy
    /// `best` (a one-node Mealy machine: the end of a memoryless stage): every node's decision
    /// law on `y` is `best`'s decision on `y` with `weight` and the uniform law with the rest;
    /// the successor laws are `template`'s at `weight`.
    pub(super) fn widened(
        best: &Controller,
        n: usize,
        n_actions: usize,
        registers: usize,
        template: Template,
        weight: f64,
    ) -> Laws {
        let y1 = best.next.len();
        let mut laws = Laws::start(n, n_actions, y1, true, registers, template, weight);
        for (r, row) in laws.act.chunks_mut(n_actions).enumerate() {
            row.fill((1.0 - weight) / n_actions as f64);
            row[best.on[r % y1] as usize] += weight;
        }
        laws
    }

    /// Mixes `weight` (`ε`) of the uniform law into every law: `p := (1 − ε)·p + ε/|row|`.
    pub(super) fn inject(&mut self, weight: f64) {
        let (a, n) = (1.0 / self.n_actions as f64, 1.0 / self.width() as f64);
        self.act.iter_mut().for_each(|p| *p = (1.0 - weight) * *p + weight * a);
        self.next.iter_mut().for_each(|p| *p = (1.0 - weight) * *p + weight * n);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};

    #[test]
    fn templates_move_their_weight_onto_their_successors() {
        let (n, a, y) = (4, 2, 3);
        let row = |laws: &Laws, q: usize, o: usize| laws.next[(q * y + o) * n..(q * y + o + 1) * n].to_vec();
        let hold = Laws::start(n, a, y, false, 0, Template::Hold, 0.6);
        // The start node stays uniform; node 2 keeps 0.6 + 0.4/4 on itself.
        assert_eq!(row(&hold, 0, 1), vec![0.25; 4]);
        assert_eq!(row(&hold, 2, 1), vec![0.1, 0.1, 0.7, 0.1]);
        let clock = Laws::start(n, a, y, false, 0, Template::Clock, 0.6);
        assert_eq!(row(&clock, 0, 2), vec![0.1, 0.7, 0.1, 0.1]);
        assert_eq!(row(&clock, 3, 0), vec![0.1, 0.1, 0.1, 0.7]);
        let mixed = Laws::start(n, a, y, false, 0, Template::Mixed, 0.6);
        assert_eq!(row(&mixed, 1, 0), vec![0.1, 0.4, 0.4, 0.1]);
        assert_eq!(row(&mixed, 0, 0), vec![0.1, 0.7, 0.1, 0.1]);
        assert_eq!(Laws::start(n, a, y, false, 0, Template::Uniform, 0.6).next, Laws::uniform(n, a, y, false).next);
        // A window: node 3 after observation 2 moves to (3·3 + 2) mod 4 = 3; node 1 after 0 to 3.
        let window = Laws::start(n, a, y, false, 0, Template::Window, 0.6);
        assert_eq!(row(&window, 3, 2), vec![0.1, 0.1, 0.1, 0.7]);
        assert_eq!(row(&window, 1, 0), vec![0.1, 0.1, 0.1, 0.7]);
        assert_eq!(row(&window, 0, 1), vec![0.1, 0.7, 0.1, 0.1]);
        for laws in [&hold, &clock, &mixed, &window] {
            assert!(laws.next.chunks(n).all(|r| (r.iter().sum::<f64>() - 1.0).abs() < 1e-12));
        }
    }

    /// The decisions `c` takes on the observations `ys` (the start observation first).
    fn decisions(c: &Controller, y1: usize, ys: &[usize]) -> Vec<u32> {
        let mut q = 0;
        ys.iter()
            .map(|&y| {
                q = c.next[q * y1 + y] as usize;
                c.act[q]
            })
            .collect()
    }

    #[test]
    fn grown_laws_draw_controllers_that_behave_as_the_one_they_grew_from() {
        let (n_actions, y1) = (3, 4);
        let mut rng = stream(9, Purpose::Optimise, 0, 0);
        for case in 0..20 {
            let best = Laws::uniform(3, n_actions, y1, false).draw(&mut rng);
            let grown = Laws::grown(&best, n_actions, y1, 0.0);
            assert_eq!((grown.nodes(), grown.shape()), (4, (n_actions, y1)));
            assert!(
                grown
                    .next
                    .chunks(4)
                    .chain(grown.act.chunks(n_actions))
                    .all(|r| (r.iter().sum::<f64>() - 1.0).abs() < 1e-12)
            );
            for k in 0..10 {
                let c = grown.draw(&mut rng);
                assert_eq!(c.nodes(), 4);
                let ys: Vec<usize> = (0..12).map(|t| (t * 7 + k * 3 + case) % y1).collect();
                assert_eq!(decisions(&c, y1, &ys), decisions(&best, y1, &ys), "case {case}");
            }
        }
        // The uniform law mixed in: every successor has some probability.
        let best = Laws::uniform(2, n_actions, y1, false).draw(&mut rng);
        assert!(Laws::grown(&best, n_actions, y1, 0.2).next.iter().all(|&p| p >= 0.2 / 3.0 - 1e-12));
    }

    #[test]
    fn draws_follow_the_laws_and_an_injection_mixes_in_the_uniform_law() {
        let mut laws = Laws::start(3, 2, 2, false, 0, Template::Hold, 0.9);
        // Frequencies of node 1's successor after observation 0: 0.9 + 0.1/3 on itself.
        let draws = 20_000;
        let held = (0..draws).filter(|&k| laws.draw(&mut stream(5, Purpose::Optimise, 0, k)).next[2] == 1).count()
            as f64
            / draws as f64;
        let p = 0.9 + 0.1 / 3.0;
        assert!((held - p).abs() < 4.0 * (p * (1.0 - p) / draws as f64).sqrt(), "{held}");
        laws.inject(0.5);
        assert!((laws.next[2 * 3 + 1] - (0.5 * p + 0.5 / 3.0)).abs() < 1e-12);
        assert!((laws.act[0] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn widened_laws_start_from_the_memoryless_policy_and_mealy_laws_refit_their_decisions() {
        let (a, y1) = (3, 4);
        let best = Controller::mealy(vec![2, 0, 1, 2], vec![0; 4], y1);
        let laws = Laws::widened(&best, 5, a, 0, Template::Hold, 0.6);
        assert!(laws.mealy && laws.nodes() == 5 && laws.act.len() == 5 * y1 * a);
        for (r, row) in laws.act.chunks(a).enumerate() {
            for (d, &p) in row.iter().enumerate() {
                let expected = if d as u32 == best.on[r % y1] { 0.6 + 0.4 / 3.0 } else { 0.4 / 3.0 };
                assert!((p - expected).abs() < 1e-12, "row {r}: {row:?}");
            }
        }
        assert_eq!(laws.next, Laws::start(5, a, y1, true, 0, Template::Hold, 0.6).next);
        // A Mealy machine is drawn, and a whole refit onto it gives its one-hot laws.
        let c = laws.draw(&mut stream(1, Purpose::Optimise, 0, 0));
        assert!(c.is_mealy() && c.on.len() == 5 * y1 && c.nodes() == 5);
        c.check(y1, a).unwrap();
        let mut refit = laws.clone();
        refit.refit(&[&c], None, 1.0);
        assert_eq!(refit, Laws::around(&c, a, y1, 1.0));
        assert!((refit.concentration() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_credited_row_moves_onto_its_best_decision_and_the_others_onto_the_elite() {
        // Two Moore nodes, three decisions; the elite decides 0 in both nodes; row 1 is
        // credited with decision 2, row 0 has no credit.
        let mut laws = Laws::uniform(2, 3, 2, false);
        let elite = Controller::moore(vec![0, 0], vec![0, 1, 1, 0]);
        laws.refit(&[&elite], Some(&[None, Some(2)]), 0.25);
        let third = 0.75 / 3.0;
        assert_eq!(laws.act, vec![third + 0.25, third, third, third, third, third + 0.25]);
        // The successor laws follow the elite either way.
        let mut plain = Laws::uniform(2, 3, 2, false);
        plain.refit(&[&elite], None, 0.25);
        assert_eq!((plain.next, &plain.act[..3]), (laws.next, &laws.act[..3]));
    }

    #[test]
    fn register_laws_draw_factored_machines_and_a_refit_finds_each_register_s_move() {
        let (a, y1, d, m) = (3, 4, 2, 3);
        let n = 8;
        let laws = Laws::start(n, a, y1, true, m, Template::Mixed, 0.5);
        assert_eq!(laws.next.len(), m * y1 * d * d * d);
        assert!(laws.next.chunks(d).all(|r| (r.iter().sum::<f64>() - 1.0).abs() < 1e-12));
        // Register 1 (i = 1) at b = 1 after y = 0 with register 0 at a = 0: held (1) and copied
        // (0) at 0.25 each, over the uniform 0.5.
        let row = y1 * d * d + 1; // ((i·Y + y)·d + a)·d + b with i = 1, y = 0, a = 0, b = 1
        assert_eq!(laws.next[row * d..(row + 1) * d], [0.5, 0.5]);
        // At b = 0 the start value is not held: all the weight on the copy of a = 1.
        let row = y1 * d * d + d; // i = 1, y = 0, a = 1, b = 0
        assert_eq!(laws.next[row * d..(row + 1) * d], [0.25, 0.75]);
        let mut rng = stream(3, Purpose::Optimise, 0, 0);
        for _ in 0..20 {
            let c = laws.draw(&mut rng);
            c.check(y1, a).unwrap();
            assert_eq!(c.nodes(), n);
            // Register i's next value depends on y and registers i − 1 and i alone.
            for (q, q2, y, i) in cases(n, y1, m) {
                let same = |j: usize| digit(q, j, d) == digit(q2, j, d);
                if same(i) && same((i + m - 1) % m) {
                    assert_eq!(digit(c.next[q * y1 + y] as usize, i, d), digit(c.next[q2 * y1 + y] as usize, i, d));
                }
            }
            // A whole refit onto it gives one-hot laws that draw it again.
            let mut refit = laws.clone();
            refit.refit(&[&c], None, 1.0);
            assert!((refit.concentration() - 1.0).abs() < 1e-12);
            assert_eq!(refit.draw(&mut rng), c);
        }
        // The window at full weight is the shift register: the first register copies y mod d,
        // the others the register before them.
        let c = Laws::start(n, a, y1, true, m, Template::Window, 1.0).draw(&mut rng);
        for q in 0..n {
            for y in 0..y1 {
                assert_eq!(c.next[q * y1 + y] as usize, y % d + d * digit(q, 0, d) + d * d * digit(q, 1, d));
            }
        }
        // Widened around a memoryless policy: its decisions, the registers' laws.
        let best = Controller::mealy(vec![2, 0, 1, 2], vec![0; 4], y1);
        let widened = Laws::widened(&best, n, a, m, Template::Mixed, 0.5);
        assert_eq!(widened.next, laws.next);
        assert!(widened.act.chunks(a).enumerate().all(|(r, row)| row[best.on[r % y1] as usize] > 0.5));
    }

    /// Every (node, node, observation, register).
    fn cases(n: usize, y1: usize, m: usize) -> impl Iterator<Item = (usize, usize, usize, usize)> {
        (0..n)
            .flat_map(move |q| (0..n).flat_map(move |q2| (0..y1).flat_map(move |y| (0..m).map(move |i| (q, q2, y, i)))))
    }
}
