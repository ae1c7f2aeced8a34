//! A memoryless policy on tiger, shared by the tests of its `.pomdp` and `.pomdpx` files.

use ceworld::{Hhmm, Layout};

/// A memoryless policy (levels `[M]`) on tiger: `node[y]` the memory state of each observation
/// (`y = 2` the start symbol), `action[m]` the action of each memory state.
pub fn reactive(node: [usize; 3], action: &[usize]) -> Hhmm {
    let m = action.len();
    let layout = Layout::new(3, 3, &[m]).unwrap();
    let mut probs = vec![0.0; layout.len];
    for (k, &a) in action.iter().enumerate() {
        probs[k * 3 + a] = 1.0;
    }
    for (y, &k) in node.iter().enumerate() {
        probs[3 * m + y * m + k] = 1.0;
    }
    Hhmm::from_flat(layout, probs).unwrap()
}
