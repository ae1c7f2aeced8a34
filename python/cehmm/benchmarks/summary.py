"""What the records add up to: each file's best controller, its ratio to SARSOP's lower bound, and the
"what this shows" paragraph, every sentence of it computed from the records."""

from __future__ import annotations

from collections import Counter
from typing import Any

#: Controllers of one family, smallest first: each can represent the ones before it.
FAMILY = ("1 node", "2 nodes", "4 nodes", "8 nodes")
#: A difference of values below this is not called a gain or a loss.
MARGIN = 0.01


def best_jobs(files: list[dict[str, Any]], jobs: dict[str, list[dict[str, Any]]]) -> dict[str, dict[str, Any]]:
    """File -> its job of highest exact value (the first of equal ones)."""
    best = {}
    for f in files:
        js = jobs.get(f["file"], [])
        if js:
            best[f["file"]] = max(js, key=lambda j: j["value"])
    return best


def ratio(facts: dict[str, Any], best: dict[str, Any] | None) -> float | None:
    """Best CE value / SARSOP LB, where both exist and LB > 0."""
    sarsop = facts.get("sarsop")
    if best is None or not sarsop or sarsop["lb"] <= 0:
        return None
    return best["value"] / sarsop["lb"]


def _names(items: list[str]) -> str:
    return ", ".join(items) if items else "none"


def _sarsop_sentences(files: list[dict[str, Any]], best: dict[str, dict[str, Any]]) -> list[str]:
    ratios: dict[str, float] = {}
    for f in files:
        r = ratio(f, best.get(f["file"]))
        if r is not None:
            ratios[f["file"]] = r
    out = []
    if ratios:
        close = [k for k, v in ratios.items() if v >= 0.99]
        far = [k for k, v in ratios.items() if v < 0.9]
        low = min(ratios, key=ratios.__getitem__)
        out.append(
            f"Of the {len(ratios)} files with a positive SARSOP lower bound, the best CE controller reaches at "
            f"least 99 % of it on {len(close)} ({_names(close)}) and less than 90 % on {len(far)} "
            f"({_names(far)}); the lowest ratio is {ratios[low]:.3f} ({low})."
        )
    above = [
        f"{f['file']} ({best[f['file']]['value']:.4f} > {f['sarsop']['ub']:.4f})"
        for f in files
        if f.get("sarsop") and f["file"] in best and best[f["file"]]["value"] > f["sarsop"]["ub"] + 1e-3
    ]
    if above:
        out.append(f"The best CE value is above SARSOP's upper bound on {_names(above)}.")
    negative = [
        f"{f['file']} ({best[f['file']]['value']:.4f} against LB {f['sarsop']['lb']:.4f})"
        for f in files
        if f.get("sarsop") and f["sarsop"]["lb"] <= 0 and f["file"] in best
    ]
    if negative:
        out.append(f"Where the lower bound is not positive: {_names(negative)}.")
    return out


def _memory_sentences(jobs: dict[str, list[dict[str, Any]]]) -> list[str]:
    gains, losses, compared = [], [], 0
    for file, js in jobs.items():
        values = {j["controller"]: j["value"] for j in js}
        if "1 node" in values and len(values) > 1:
            compared += 1
            top = max(values, key=values.__getitem__)
            if values[top] > values["1 node"] + MARGIN:
                gains.append((values[top] - values["1 node"], file, top, values["1 node"], values[top]))
        family = [c for c in FAMILY if c in values]
        for i, small in enumerate(family):
            worse = [big for big in family[i + 1 :] if values[big] < values[small] - MARGIN]
            if worse:
                losses.append(f"{file} ({', '.join(worse)} below {small})")
                break
    out = []
    if compared:
        text = (
            f"A controller with memory beats the blind 1-node one by more than {MARGIN:g} on {len(gains)} of "
            f"{compared} files"
        )
        if gains:
            g = max(gains)
            text += f" (largest gain on {g[1]}: {g[3]:.4f} with 1 node, {g[4]:.4f} with {g[2]})"
        out.append(text + ".")
    if losses:
        out.append(f"A larger k-node controller scored more than {MARGIN:g} below a smaller one on {_names(losses)}.")
    return out


def _method_sentences(jobs: dict[str, list[dict[str, Any]]]) -> list[str]:
    """The search over deterministic controllers against the best controller learned from episodes."""
    better, worse, compared = [], [], 0
    for file, js in jobs.items():
        searched = [j for j in js if j["settings"].get("method") == "controller"]
        episodic = [j for j in js if j["settings"].get("method") != "controller"]
        if not searched or not episodic:
            continue
        compared += 1
        s, e = searched[0]["value"], max(j["value"] for j in episodic)
        if s > e + MARGIN:
            better.append(f"{file} ({e:.4f} → {s:.4f})")
        elif s < e - MARGIN:
            worse.append(f"{file} ({s:.4f} against {e:.4f})")
    if not compared:
        return []
    text = (
        f"The controller search (model §8) beats the best controller learned from episodes by more than "
        f"{MARGIN:g} on {len(better)} of {compared} files"
    )
    text += f" ({_names(better)})" if better else ""
    text += f" and scores more than {MARGIN:g} below it on {len(worse)}" + (f" ({_names(worse)})" if worse else "")
    return [text + "."]


def findings(files: list[dict[str, Any]], jobs: dict[str, list[dict[str, Any]]]) -> str:
    """The "what this shows" paragraph: counts, ratios and differences read off the records, nothing else."""
    every = [j for js in jobs.values() for j in js]
    refused = [f["error"] for f in files if f["parse"] != "ok"]
    read = len(files) - len(refused)
    refused_text = f" ({_names(refused)})" if refused else ""
    sentences = [f"This run covers {len(files)} file(s): {read} read, {len(refused)} refused{refused_text}."]
    if not every:
        return " ".join([*sentences, "No job finished."])
    best = best_jobs(files, jobs)
    sentences += _sarsop_sentences(files, best)
    sentences += _memory_sentences(jobs)
    sentences += _method_sentences(jobs)
    deterministic = sum(j["deterministic"] for j in every)
    stops = Counter(j["stop_reason"] for j in every)
    stop_text = ", ".join(f"{reason} {n}" for reason, n in sorted(stops.items()))
    sentences.append(
        f"{deterministic} of the {len(every)} learned controllers are deterministic; stop reasons: {stop_text}."
    )
    return " ".join(sentences)
