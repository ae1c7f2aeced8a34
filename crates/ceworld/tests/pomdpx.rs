//! APPL's `.pomdpx` files, flattened (model §7): the real files against their `.pomdp` twins
//! (tables and exact values), a factored model checked entry by entry by hand, every refusal
//! by its message, and damaged documents (never a panic; `POMDPX_FUZZ_ITERS` mutations of each,
//! default 2000, from `POMDPX_FUZZ_SEED`).

#[path = "common/rng.rs"]
mod rng;
#[path = "common/temp.rs"]
mod temp;
#[path = "common/tiger.rs"]
mod tiger;

use std::panic::{AssertUnwindSafe, catch_unwind};

use ceworld::exact::{finite_horizon, infinite_horizon};
use ceworld::world::cassandra::{self, Options, Pomdp};
use ceworld::world::pomdpx;
use ceworld::{Error, PomdpWorld, random_policy};
use rng::Rng;
use tiger::reactive;

fn path(dir: &str, name: &str) -> String {
    format!("{}/../../data/{dir}/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn read_x(name: &str) -> Pomdp {
    pomdpx::parse_bytes(&std::fs::read(path("pomdpx", name)).unwrap(), &Options::default()).unwrap()
}

fn read_p(name: &str) -> Pomdp {
    cassandra::parse_file(std::path::Path::new(&path("pomdp", name)), &Options::default()).unwrap()
}

fn close(a: &[f64], b: &[f64], tol: f64) {
    assert_eq!(a.len(), b.len());
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!((x - y).abs() <= tol, "entry {i}: {x} != {y}");
    }
}

#[test]
fn tiger_pomdpx_has_the_tables_of_tiger_95() {
    let (x, p) = (read_x("Tiger.pomdpx"), read_p("tiger.95.POMDP"));
    assert_eq!((&x.states, &x.actions, x.discount), (&p.states, &p.actions, p.discount));
    assert_eq!(x.observations, ["obs-left", "obs-right"], "the .pomdp names them tiger-left, tiger-right");
    assert_eq!((&x.transition, &x.observation, &x.start), (&p.transition, &p.observation, &p.start));
    assert_eq!(x.expected_reward(), p.expected_reward());
    assert!(x.renormalised.is_empty() && !x.reward_depends_on_next());
}

#[test]
fn tiger_pomdpx_gives_the_exact_values_of_tiger_95() {
    for horizon in [1, 7, 40] {
        let x = PomdpWorld::from_file(path("pomdpx", "Tiger.pomdpx"), horizon, None).unwrap();
        let p = PomdpWorld::from_file(path("pomdp", "tiger.95.POMDP"), horizon, None).unwrap();
        let mut policies = vec![reactive([0, 0, 0], &[0]), reactive([2, 1, 0], &[0, 1, 2])];
        policies.extend((0..4).map(|seed| random_policy(&x, &[3, 2], seed).unwrap()));
        for (k, policy) in policies.iter().enumerate() {
            let (vx, vp) =
                (finite_horizon(&x, policy, None).unwrap().value, finite_horizon(&p, policy, None).unwrap().value);
            assert!((vx - vp).abs() <= 1e-12 * vp.abs().max(1.0), "H={horizon}, policy {k}: {vx} != {vp}");
            let (ix, ip) =
                (infinite_horizon(&x, policy, 1e-9).unwrap().value, infinite_horizon(&p, policy, 1e-9).unwrap().value);
            assert!((ix - ip).abs() <= 1e-9, "policy {k}: {ix} != {ip}");
        }
        // Listen, then open the door opposite to the last observation (pomdp_world.rs, by hand).
        let expected = -1.0 + 0.95 * -6.5 - 45.0 * 0.95f64.powi(2) / 0.05;
        assert!((infinite_horizon(&x, &policies[1], 1e-9).unwrap().value - expected).abs() < 1e-9);
        assert_eq!(x.tables().expected_reward(1, 1), p.tables().expected_reward(1, 1));
    }
}

#[test]
fn hallway_pomdpx_is_hallway_pomdp() {
    // APPL's Hallway.pomdpx pays the goal's reward in expectation over (a, s); hallway.POMDP on
    // entering it (s'): the same expected rewards, hence the same values.
    let (x, p) = (read_x("Hallway.pomdpx"), read_p("hallway.POMDP"));
    assert_eq!((x.num_states(), x.num_actions(), x.num_observations()), (60, 5, 21));
    assert_eq!((&x.transition, &x.observation, &x.start), (&p.transition, &p.observation, &p.start));
    close(&x.expected_reward(), &p.expected_reward(), 1e-15);
    let wx = PomdpWorld::from_file(path("pomdpx", "Hallway.pomdpx"), 30, None).unwrap();
    let wp = PomdpWorld::from_file(path("pomdp", "hallway.POMDP"), 30, None).unwrap();
    let policy = random_policy(&wx, &[3, 2], 5).unwrap();
    let (vx, vp) =
        (finite_horizon(&wx, &policy, None).unwrap().value, finite_horizon(&wp, &policy, None).unwrap().value);
    assert!((vx - vp).abs() < 1e-12, "{vx} != {vp}");
}

#[test]
fn tag_avoid_pomdpx_shows_the_robot_it_fully_observes() {
    let x = read_x("TagAvoid.pomdpx");
    let p = read_p("TagAvoid.pomdp");
    // 29 robot cells × 30 target values; an observation is the robot's cell (fullyObs) and the
    // sensor's value, of which 58 of the 29 × 30 can be emitted.
    assert_eq!((x.num_states(), x.num_actions(), x.num_observations()), (870, 5, 58));
    assert_eq!((x.states[0].as_str(), x.observations[0].as_str()), ("Srv4rh0_Ttv4th0", "Srv4rh0_Orv4rh0"));
    let (ns, no) = (870, 58);
    for (r, row) in x.observation.chunks(no).enumerate() {
        let robot = x.states[r % ns].split('_').next().unwrap();
        for (o, &prob) in row.iter().enumerate() {
            assert!(prob == 0.0 || x.observations[o].starts_with(&format!("{robot}_")), "{r} {o}");
        }
    }
    close(&x.expected_reward(), &p.expected_reward(), 1e-12);
    close(x.start.as_ref().unwrap(), p.start.as_ref().unwrap(), 1e-9);
    // The two encodings of Tag differ in 16 of the 4350 rows of T (e.g. North from Srv3rh9_Ttv3th9:
    // the target stays with 0.6 here, 0.5 in the .pomdp).
    let differing = x.transition.chunks(ns).zip(p.transition.chunks(ns)).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 16);
    let north = 589 * ns;
    assert_eq!((x.transition[north + 589], p.transition[north + 589]), (0.6, 0.5));
}

#[test]
fn rock_sample_7_8_is_refused_for_its_size() {
    let e = PomdpWorld::from_file(path("pomdpx", "RockSample_7_8.pomdpx"), 10, None).unwrap_err();
    let Error::ModelFormat(message) = &e else { panic!("{e:?}") };
    assert!(message.contains("RockSample_7_8.pomdpx:14:1: the model is too large"), "{message}");
    assert!(
        message.contains(
            "12800 (50 x 2 x 2 x 2 x 2 x 2 x 2 x 2 x 2) states, 13 actions and 100 (50 x 2) observations the \
             transition table T (A x S x S) would have more than 67108864 entries"
        ),
        "{message}"
    );
}

/// Two hidden state variables (`x` then `y`, y's law depending on the new x), two action
/// variables, two observation variables (`see` depending on `hear`), an initial belief with a
/// parent, entries overriding others, and two reward functions summed.
const FACTORED: &str = r#"<?xml version="1.0"?>
<pomdpx version="1.0">
<Discount>0.9</Discount>
<Variable>
  <StateVar vnamePrev="x0" vnameCurr="x1"><ValueEnum>a b</ValueEnum></StateVar>
  <StateVar vnamePrev="y0" vnameCurr="y1" fullyObs="false"><NumValues>3</NumValues></StateVar>
  <ObsVar vname="hear"><ValueEnum>h0 h1</ValueEnum></ObsVar>
  <ObsVar vname="see"><NumValues>2</NumValues></ObsVar>
  <ActionVar vname="move"><ValueEnum>stay flip</ValueEnum></ActionVar>
  <ActionVar vname="say"><ValueEnum>quiet loud</ValueEnum></ActionVar>
  <RewardVar vname="r1"/>
  <RewardVar vname="r2"/>
</Variable>
<InitialStateBelief>
  <CondProb><Var>x0</Var><Parent>null</Parent><Parameter type="TBL">
    <Entry><Instance>-</Instance><ProbTable>0.25 0.75</ProbTable></Entry></Parameter></CondProb>
  <CondProb><Var>y0</Var><Parent>x0</Parent><Parameter>
    <Entry><Instance>a -</Instance><ProbTable>1 0 0</ProbTable></Entry>
    <Entry><Instance>b -</Instance><ProbTable>uniform</ProbTable></Entry></Parameter></CondProb>
</InitialStateBelief>
<StateTransitionFunction>
  <CondProb><Var>x1</Var><Parent>move x0</Parent><Parameter>
    <Entry><Instance>stay - -</Instance><ProbTable>identity</ProbTable></Entry>
    <Entry><Instance>flip - -</Instance><ProbTable>0 1 1 0</ProbTable></Entry></Parameter></CondProb>
  <CondProb><Var>y1</Var><Parent>y0 x1</Parent><Parameter>
    <Entry><Instance>* a -</Instance><ProbTable>0.5 0.5 0</ProbTable></Entry>
    <Entry><Instance>- b -</Instance><ProbTable>0 1 0  0 0 1  1 0 0</ProbTable></Entry></Parameter></CondProb>
</StateTransitionFunction>
<ObsFunction>
  <CondProb><Var>hear</Var><Parent>say x1</Parent><Parameter>
    <Entry><Instance>quiet * -</Instance><ProbTable>0.5 0.5</ProbTable></Entry>
    <Entry><Instance>loud a -</Instance><ProbTable>0.9 0.1</ProbTable></Entry>
    <Entry><Instance>1 b -</Instance><ProbTable>0.2 0.8</ProbTable></Entry></Parameter></CondProb>
  <CondProb><Var>see</Var><Parent>y1 hear</Parent><Parameter>
    <Entry><Instance>* h0 -</Instance><ProbTable>0.7 0.3</ProbTable></Entry>
    <Entry><Instance>* h1 -</Instance><ProbTable>0.4 0.6</ProbTable></Entry>
    <Entry><Instance>s2 * -</Instance><ProbTable>0 1</ProbTable></Entry></Parameter></CondProb>
</ObsFunction>
<RewardFunction>
  <Func><Var>r1</Var><Parent>move x0</Parent><Parameter>
    <Entry><Instance>flip *</Instance><ValueTable>-1</ValueTable></Entry>
    <Entry><Instance>stay b</Instance><ValueTable>2</ValueTable></Entry></Parameter></Func>
  <Func><Var>r2</Var><Parent>y1 see</Parent><Parameter>
    <Entry><Instance>- o0</Instance><ValueTable>1 2 3</ValueTable></Entry>
    <Entry><Instance>s1 o1</Instance><ValueTable>5</ValueTable></Entry></Parameter></Func>
</RewardFunction>
</pomdpx>
"#;

#[test]
fn a_factored_model_flattened_by_hand() {
    let m = pomdpx::parse(FACTORED, &Options::default()).unwrap();
    assert_eq!(m.states, ["a_s0", "a_s1", "a_s2", "b_s0", "b_s1", "b_s2"]);
    assert_eq!(m.actions, ["stay_quiet", "stay_loud", "flip_quiet", "flip_loud"]);
    assert_eq!(m.observations, ["h0_o0", "h0_o1", "h1_o0", "h1_o1"]);
    assert_eq!(m.discount, Some(0.9));
    // x first (slowest): s = 3x + y; a = 2·move + say; o = 2·hear + see.
    assert_eq!(m.start.as_deref(), Some(&[0.25, 0.0, 0.0, 0.25, 0.25, 0.25][..]));
    let t = |a: usize, s: usize, s2: usize| m.transition[(a * 6 + s) * 6 + s2];
    let o = |a: usize, s2: usize, o: usize| m.observation[(a * 6 + s2) * 4 + o];
    // Flip from a_s2: x becomes b, and y moves on from s2 to s0 when x is b.
    assert_eq!((t(2, 2, 3), t(2, 2, 4), t(3, 2, 3)), (1.0, 0.0, 1.0));
    // Stay in a: y is uniform over s0, s1 whatever it was.
    assert_eq!((t(0, 2, 0), t(0, 2, 1), t(0, 2, 2), t(1, 5, 3)), (0.5, 0.5, 0.0, 1.0));
    // Loud in a_s2: hear h0 with 0.9, and see o1 surely in s2 (the later entry).
    assert_eq!((o(1, 2, 0), o(1, 2, 1), o(1, 2, 3)), (0.0, 0.9, 0.1));
    // Quiet in b_s0: hear h1 with 0.5, then see o0 with 0.4.
    assert!((o(0, 3, 2) - 0.2).abs() < 1e-15 && (o(3, 3, 2) - 0.8 * 0.4).abs() < 1e-15);
    // Every entry against the model as written.
    let tx = |mv: usize, x: usize, x2: usize| f64::from(u8::from(if mv == 0 { x2 == x } else { x2 != x }));
    let ty = |y: usize, x2: usize, y2: usize| match x2 {
        0 => [0.5, 0.5, 0.0][y2],
        _ => f64::from(u8::from(y2 == (y + 1) % 3)),
    };
    let hear = |say: usize, x2: usize, h: usize| match (say, x2) {
        (0, _) => 0.5,
        (_, 0) => [0.9, 0.1][h],
        _ => [0.2, 0.8][h],
    };
    let see = |y2: usize, h: usize, v: usize| match (y2, h) {
        (2, _) => [0.0, 1.0][v],
        (_, 0) => [0.7, 0.3][v],
        _ => [0.4, 0.6][v],
    };
    let reward = |mv: usize, x: usize, y2: usize, v: usize| {
        let r1 = match (mv, x) {
            (1, _) => -1.0,
            (0, 1) => 2.0,
            _ => 0.0,
        };
        r1 + if v == 0 {
            [1.0, 2.0, 3.0][y2]
        } else if y2 == 1 {
            5.0
        } else {
            0.0
        }
    };
    for a in 0..4 {
        let (mv, say) = (a / 2, a % 2);
        for s in 0..6 {
            for s2 in 0..6 {
                let (x, y, x2, y2) = (s / 3, s % 3, s2 / 3, s2 % 3);
                assert_eq!(t(a, s, s2), tx(mv, x, x2) * ty(y, x2, y2), "T a={a} s={s} s'={s2}");
                for obs in 0..4 {
                    let (h, v) = (obs / 2, obs % 2);
                    let expected = hear(say, x2, h) * see(y2, h, v);
                    assert!((o(a, s2, obs) - expected).abs() < 1e-15, "O a={a} s'={s2} o={obs}");
                    if t(a, s, s2) > 0.0 && expected > 0.0 {
                        assert_eq!(m.reward(a, s, s2, obs), reward(mv, x, y2, v), "R a={a} s={s} s'={s2} o={obs}");
                    }
                }
            }
        }
    }
    // The rewards depend on (a, s, s', o): one entry a combination that can happen, nonzero.
    assert!(m.reward_depends_on_next());
    assert!(m.rewards.iter().all(|e| e.action.is_some() && e.next_state.is_some() && e.observation.is_some()));
}

#[test]
fn a_fully_observed_variable_is_part_of_the_observation() {
    let doc = r#"<pomdpx><Discount>1</Discount><Variable>
      <StateVar vnamePrev="pos0" vnameCurr="pos1" fullyObs="true"><ValueEnum>l r</ValueEnum></StateVar>
      <StateVar vnamePrev="h0" vnameCurr="h1"><ValueEnum>u v</ValueEnum></StateVar>
      <ObsVar vname="ping"><ValueEnum>p0 p1</ValueEnum></ObsVar>
      <ActionVar vname="act"><ValueEnum>go</ValueEnum></ActionVar></Variable>
      <StateTransitionFunction>
        <CondProb><Var>pos1</Var><Parent>act pos0</Parent><Parameter>
          <Entry><Instance>go - -</Instance><ProbTable>0 1 1 0</ProbTable></Entry></Parameter></CondProb>
        <CondProb><Var>h1</Var><Parent>h0</Parent><Parameter>
          <Entry><Instance>- -</Instance><ProbTable>identity</ProbTable></Entry></Parameter></CondProb>
      </StateTransitionFunction>
      <ObsFunction><CondProb><Var>ping</Var><Parent>pos1</Parent><Parameter>
          <Entry><Instance>l -</Instance><ProbTable>1 0</ProbTable></Entry>
          <Entry><Instance>r -</Instance><ProbTable>0.5 0.5</ProbTable></Entry></Parameter></CondProb>
      </ObsFunction></pomdpx>"#;
    let m = pomdpx::parse(doc, &Options::default()).unwrap();
    // pos × ping, less l_p1, which no state emits.
    assert_eq!(m.observations, ["l_p0", "r_p0", "r_p1"]);
    assert_eq!(m.observation, [1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.5, 0.5]);
    assert_eq!((m.start, m.rewards.len(), m.discount), (None, 0, Some(1.0)));
}

/// The message of `pomdpx::parse(doc)`'s error, prefixed with its line.
fn refusal(doc: &str, options: &Options) -> String {
    let e = pomdpx::parse(doc, options).map(|_| ()).unwrap_err();
    assert!(e.line > 0 && e.column > 0, "{e:?}");
    e.to_string()
}

/// Edits of Tiger.pomdpx (`from` -> `to`) and what the refusal says.
const EDITS: &[(&str, &str, &str)] = &[
    (
        "0.85 0.15 0.15 0.85",
        "0.85 0.25 0.15 0.85",
        "65:1: the <CondProb> of obs_sensor (line 61): the probabilities at action_agent=listen, state_1=tiger-left sum to 1.1 (expected 1 within 1e-5)",
    ),
    (
        "<Parent>action_agent state_0</Parent>",
        "<Parent>action_agent state_9</Parent>",
        "unknown parent 'state_9' in <CondProb> (expected a declared variable: state_0, state_1, obs_sensor, action_agent, reward_agent)",
    ),
    (
        "<Instance>open-left * *</Instance>",
        "<Instance>open-up * *</Instance>",
        "unknown value 'open-up' of variable action_agent (expected one of: listen, open-left, open-right; an index below 3; '*' or '-')",
    ),
    (
        "<Instance>listen *</Instance>",
        "<Instance>listen * *</Instance>",
        "<Instance>listen * *</Instance> has 3 values (expected 2: one of each of action_agent, state_0)",
    ),
    (
        "<ProbTable>0.85 0.15 0.15 0.85</ProbTable>",
        "<ProbTable>0.85 0.15 0.15</ProbTable>",
        "<ProbTable> has 3 numbers (expected 4: one for each combination",
    ),
    (
        "<ProbTable>0.5 0.5</ProbTable>",
        "<ProbTable>-0.5 1.5</ProbTable>",
        "'-0.5' in <ProbTable> (expected a probability: a number in [0, 1])",
    ),
    ("<ValueTable>10</ValueTable>", "<ValueTable>1e999</ValueTable>", "'1e999' in <ValueTable> (expected a number)"),
    (
        "<ProbTable>identity</ProbTable>",
        "<ProbTable>uniform identity</ProbTable>",
        "(expected 'identity' and 'uniform' stand alone)",
    ),
    (
        "<Instance>listen - -</Instance>\n<ProbTable>identity",
        "<Instance>listen * -</Instance>\n<ProbTable>identity",
        "'identity' needs <Instance> to end with two '-'",
    ),
    (
        "<Parameter type = \"TBL\">\n<Entry>\n<Instance>listen - -</Instance>\n<ProbTable>identity",
        "<Parameter type = \"DD\">\n<Entry>\n<Instance>listen - -</Instance>\n<ProbTable>identity",
        "<Parameter type=\"DD\">: decision diagrams are not supported (expected type=\"TBL\"",
    ),
    (
        "<Parent>action_agent state_1</Parent>",
        "<Parent>action_agent state_0</Parent>",
        "state_0 as a parent in <ObsFunction>'s <CondProb> (expected an action, a state variable's vnameCurr or another observation variable (an observation that depends on the previous state is not an O(o|a,s'))",
    ),
    (
        "<Var>state_1</Var>",
        "<Var>state_0</Var>",
        "state_0 as a variable in <StateTransitionFunction>'s <CondProb> (expected a state variable's vnameCurr)",
    ),
    (
        "<ObsVar vname=\"obs_sensor\">",
        "<ObsVar vname=\"state_0\">",
        "variable name 'state_0' declared twice (first on line 12)",
    ),
    (
        "<ValueEnum>obs-left obs-right</ValueEnum>",
        "<ValueEnum>obs-left obs-left</ValueEnum>",
        "value 'obs-left' of obs_sensor is listed twice",
    ),
    ("<Discount>0.95</Discount>", "<Discount>1.5</Discount>", "<Discount>1.5</Discount> (expected a number in [0, 1])"),
    (
        "</RewardFunction>",
        "</RewardFunction><TerminalStateRewardFunction/>",
        "unknown element <TerminalStateRewardFunction> in <pomdpx>",
    ),
    ("<ObsFunction>", "<ObsFunction><Func/>", "<Func> in <ObsFunction> (expected <CondProb>s)"),
    (
        "</StateTransitionFunction>",
        "</StateTransitionFunction><StateTransitionFunction><CondProb><Var>state_1</Var><Parent>state_0</Parent><Parameter/></CondProb></StateTransitionFunction>",
        "a second <CondProb> of state_1 in <StateTransitionFunction> (the first is on line 42)",
    ),
    (
        "<Entry>\n<Instance>open-left * *</Instance>\n<ProbTable>0.5</ProbTable></Entry>",
        "",
        "T(.|a=open-left, s=tiger-left), the product of the <CondProb>s, sums to 0 (expected 1 within 1e-5): the <CondProb> of state_1 (line 42) has no <Entry> at action_agent=open-left, state_0=tiger-left",
    ),
    (
        "</ObsVar>",
        "</ObsVar><ObsVar vname=\"extra\"><NumValues>2</NumValues></ObsVar>",
        "59:1: no <CondProb> of extra in <ObsFunction> (expected one per variable)",
    ),
    (
        "<Parent>action_agent state_0</Parent>",
        "<Parent>null</Parent>",
        "null in <StateTransitionFunction> (expected variable names: no parents is null only in <InitialStateBelief>)",
    ),
    ("</pomdpx>", "", "not well-formed XML"),
    ("<pomdpx version", "<pomdp version", "not well-formed XML"),
];

#[test]
fn every_refusal_names_what_is_wrong_and_where() {
    let tiger = std::fs::read_to_string(path("pomdpx", "Tiger.pomdpx")).unwrap();
    let options = Options::default();
    let edited = |from: &str, to: &str| {
        assert!(tiger.contains(from), "{from}");
        tiger.replacen(from, to, 1)
    };
    for (from, to, expected) in EDITS {
        let message = refusal(&edited(from, to), &options);
        assert!(message.contains(expected), "{from} -> {to}:\n  {message}\n  (expected {expected})");
    }
    // ISO-8859-1 where declared (APPL's files declare it), else UTF-8: a byte 0xE9 (é).
    let with_e_acute = |encoding: &str| {
        let text = tiger.replacen("ISO-8859-1", encoding, 1).replacen("This is", "\u{1} is", 1);
        text.into_bytes().into_iter().map(|b| if b == 1 { 0xE9 } else { b }).collect::<Vec<u8>>()
    };
    assert_eq!(pomdpx::parse_bytes(&with_e_acute("ISO-8859-1"), &options).unwrap(), read_x("Tiger.pomdpx"));
    let e = pomdpx::parse_bytes(&with_e_acute("UTF-8"), &options).unwrap_err().to_string();
    assert_eq!(
        e,
        "7:14: bytes that are not UTF-8 (expected UTF-8, or ISO-8859-1 declared as the XML declaration's encoding)"
    );
    let message = refusal("<?xml version=\"1.0\"?>\n<pomdp/>", &options);
    assert_eq!(message, "2:1: the root element is <pomdp> (expected <pomdpx>)");
}

#[test]
fn rows_within_the_tolerance_value_indices_and_the_size_limits() {
    let tiger = std::fs::read_to_string(path("pomdpx", "Tiger.pomdpx")).unwrap();
    let options = Options::default();
    let edited = |from: &str, to: &str| tiger.replacen(from, to, 1);
    // Within the tolerance a row is renormalised and noted.
    let m = pomdpx::parse(&edited("0.85 0.15 0.15 0.85", "0.85 0.150004 0.15 0.85"), &options).unwrap();
    assert_eq!(
        m.renormalised,
        [
            "the <CondProb> of obs_sensor (line 61) at action_agent=listen, state_1=tiger-left summed to 1.000004; renormalised"
        ]
    );
    assert!((m.observation[0] - 0.85 / 1.000_004).abs() < 1e-15);
    // A value by its index is the value.
    assert_eq!(pomdpx::parse(&edited("open-left * *", "1 * *"), &options).unwrap(), read_x("Tiger.pomdpx"));
    // Past max_entries: the flat tables (A x S x S = 144 here), or the table of one <CondProb>
    // (y1's, 3 x 2 x 3 = 18).
    let message = refusal(FACTORED, &Options { max_entries: 100, ..Options::default() });
    assert_eq!(
        message,
        "4:1: the model is too large: with 6 (2 x 3) states, 4 (2 x 2) actions and 4 (2 x 2) observations the \
         transition table T (A x S x S) would have more than 100 entries"
    );
    let message = refusal(FACTORED, &Options { max_entries: 17, ..Options::default() });
    assert_eq!(
        message,
        "25:3: the table of the <CondProb> of y1 would have more than 17 entries (3 x 2 x 3 values of its variables)"
    );
}

#[test]
fn the_world_reads_either_format_and_refuses_by_file_and_line() {
    let dir = temp::TempPath::new("ceworld-pomdpx", "bad.pomdpx");
    let tiger = std::fs::read_to_string(path("pomdpx", "Tiger.pomdpx")).unwrap();
    // Sniffed by content, not by name: an XML document named .pomdp is read as .pomdpx.
    let renamed = dir.with_file_name("tiger.pomdp");
    std::fs::write(&renamed, &tiger).unwrap();
    let world = PomdpWorld::from_file(renamed.to_str().unwrap(), 5, None).unwrap();
    assert_eq!(world.tables().pomdp.observations, ["obs-left", "obs-right"]);
    std::fs::write(&*dir, tiger.replace("0.85 0.15 0.15", "0.85 0.15 0.16")).unwrap();
    let e = PomdpWorld::from_file(dir.to_str().unwrap(), 5, None).unwrap_err();
    let Error::ModelFormat(message) = &e else { panic!("{e:?}") };
    assert!(message.starts_with(&format!("{}:65:1: the <CondProb> of obs_sensor", dir.display())), "{message}");
    // Larger than the most bytes read: refused before reading (a sparse file).
    let big = std::fs::File::create(&*dir).unwrap();
    big.set_len(ceworld::world::pomdp::MAX_FILE_BYTES + 1).unwrap();
    let e = PomdpWorld::from_file(dir.to_str().unwrap(), 5, None).unwrap_err().to_string();
    assert!(e.contains("bytes (at most 268435456 are read)"), "{e}");
}

/// Tokens likely to reach the corners of the reader.
const TOKENS: &[&str] = &[
    "*",
    "-",
    "null",
    "identity",
    "uniform",
    "0",
    "1",
    "2",
    "7",
    "0.5",
    "-1",
    "1e999",
    "nan",
    "</Entry>",
    "<Entry>",
    "<Instance>",
    "</Instance>",
    "<ProbTable>",
    "a",
    "b",
    "s2",
    "h1",
    "o1",
    "x0",
    "y1",
    "flip",
    "see",
    "&amp;",
    "<!-- -->",
];

fn mutate(text: &mut Vec<u8>, rng: &mut Rng) {
    let n = text.len().max(1);
    match rng.below(6) {
        0 => text.truncate(rng.below(n)),
        1 => {
            let i = rng.below(n).min(text.len().saturating_sub(1));
            if let Some(b) = text.get_mut(i) {
                *b ^= 1 << rng.below(8);
            }
        }
        2 => {
            let start = rng.below(n).min(text.len());
            let end = (start + 1 + rng.below(40)).min(text.len());
            text.drain(start..end);
        }
        3 => {
            let start = rng.below(n).min(text.len());
            let end = (start + 1 + rng.below(60)).min(text.len());
            let span = text[start..end].to_vec();
            let at = rng.below(n).min(text.len());
            text.splice(at..at, span);
        }
        _ => {
            // A whitespace-separated token replaced with an interesting one.
            let spaces: Vec<usize> = (0..text.len()).filter(|&i| text[i] == b' ' || text[i] == b'>').collect();
            if let Some(&i) = spaces.get(rng.below(spaces.len())) {
                let end = (i + 1..text.len()).find(|&j| matches!(text[j], b' ' | b'<')).unwrap_or(text.len());
                let token = TOKENS[rng.below(TOKENS.len())].as_bytes().to_vec();
                text.splice(i + 1..end, token);
            }
        }
    }
}

#[test]
fn damaged_documents_are_read_or_refused_never_a_panic() {
    let env = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<u64>().ok());
    let iterations = env("POMDPX_FUZZ_ITERS").unwrap_or(2000) as usize;
    let seed = env("POMDPX_FUZZ_SEED").unwrap_or(0x5EED_F11E);
    let tiger = std::fs::read(path("pomdpx", "Tiger.pomdpx")).unwrap();
    let options = Options::default();
    for (name, good) in [("tiger", tiger), ("factored", FACTORED.as_bytes().to_vec())] {
        let mut rng = Rng((seed ^ name.len() as u64) | 1);
        let (mut read, mut refused) = (0, 0);
        for case in 0..iterations {
            let mut bytes = good.clone();
            for _ in 0..=rng.below(3) {
                mutate(&mut bytes, &mut rng);
            }
            let outcome = catch_unwind(AssertUnwindSafe(|| pomdpx::parse_bytes(&bytes, &options)));
            match outcome.unwrap_or_else(|_| panic!("{name}: case {case} panicked")) {
                Ok(m) => {
                    read += 1;
                    let (ns, na, no) = (m.num_states(), m.num_actions(), m.num_observations());
                    assert_eq!((m.transition.len(), m.observation.len()), (na * ns * ns, na * ns * no));
                    for row in m.transition.chunks(ns).chain(m.observation.chunks(no)) {
                        assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{name}: case {case}: a row off 1");
                    }
                    let fits = |e: &cassandra::RewardEntry| {
                        e.action.is_none_or(|a| a < na)
                            && e.state.is_none_or(|s| s < ns)
                            && e.next_state.is_none_or(|s| s < ns)
                            && e.observation.is_none_or(|o| o < no)
                    };
                    assert!(m.rewards.iter().all(|e| fits(e) && e.value.is_finite()), "{name}: case {case}");
                }
                Err(e) => {
                    refused += 1;
                    assert!(e.line > 0 && !e.message.is_empty(), "{name}: case {case}: {e:?}");
                }
            }
        }
        println!("{name}: {iterations} damaged documents, {refused} refused, {read} read, no panic");
        assert!(refused > iterations / 2, "{name}: {refused} refused");
    }
}
