#!/usr/bin/env python3
"""Train an rl-starter-files / torch-ac ``ACModel`` with PPO on a registered level (BabyAI's
or MiniGrid's), in PyTorch, and save it as rl-starter-files saves it (``status.pt``:
``model_state``, ``vocab``, ``num_frames``), ready for ``export_acmodel.py --status``.

    python export/train_acmodel.py --env BabyAI-GoToRedBallGrey-v0 --frames 400000 \\
        --out storage/GoToRedBallGrey
    python export/train_acmodel.py --env MiniGrid-DoorKey-5x5-v0 --no-mem --no-text \\
        --frames 100000 --out storage/DoorKey

This is the agent of docs/onnx.md's "your agent on your level": trained entirely outside
groundscope, by the recipe rl-starter-files' ``scripts/train.py --algo ppo`` uses (16
environments × 128 frames, 4 epochs of 256-frame minibatches, Adam 1e-3, γ 0.99, λ 0.95,
clip 0.2, entropy 0.01, value 0.5, gradient norm 0.5; with memory, recurrence 4 as
rl-starter-files' ``--recurrence 4``, without it 1), written out here in one file so that it
runs with torch, gymnasium and minigrid alone. Memory (``--mem``, an ``LSTMCell``) and text
(``--text``, a GRU over the mission) are on by default here; ``--no-mem --no-text`` is
rl-starter-files' default model, the image alone. The model class is
``export_acmodel.ACModel`` (rl-starter-files' own, reproduced there). Missions are tokenised as
rl-starter-files does — ``re.findall("([a-z]+)", mission.lower())``, ids in first-seen order
from 1 (0 pads) — and the vocabulary is saved with the weights.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections import deque
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import minigrid  # noqa: F401  (registers the BabyAI levels)
import numpy as np
import torch
import torch.nn.functional as F

sys.path.insert(0, str(Path(__file__).resolve().parent))

from export_acmodel import ACModel  # noqa: E402


class Vocabulary:
    """rl-starter-files' ``utils.format.Vocabulary``: ids in first-seen order, at most
    ``max_size``."""

    def __init__(self, max_size: int):
        self.max_size = max_size
        self.vocab: dict[str, int] = {}

    def __getitem__(self, token: str) -> int:
        if token not in self.vocab:
            if len(self.vocab) >= self.max_size:
                raise ValueError("Maximum vocabulary capacity reached")
            self.vocab[token] = len(self.vocab) + 1
        return self.vocab[token]


def preprocess(obss, vocab: Vocabulary) -> SimpleNamespace:
    """rl-starter-files' ``preprocess_obss`` for MiniGrid: the image as float codes, the
    mission as zero-padded ids."""
    image = torch.tensor(np.array([o["image"] for o in obss]), dtype=torch.float)
    ids = [[vocab[t] for t in re.findall("([a-z]+)", o["mission"].lower())] for o in obss]
    text = np.zeros((len(ids), max(len(i) for i in ids)), dtype=np.int64)
    for k, row in enumerate(ids):
        text[k, : len(row)] = row
    return SimpleNamespace(image=image, text=torch.tensor(text))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="BabyAI-GoToRedBallGrey-v0")
    ap.add_argument("--frames", type=int, default=400_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--procs", type=int, default=16)
    ap.add_argument("--frames-per-proc", type=int, default=128)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--mem", action=argparse.BooleanOptionalAction, default=True,
                    help="an LSTMCell memory (default on)")
    ap.add_argument("--text", action=argparse.BooleanOptionalAction, default=True,
                    help="a GRU over the mission (default on)")
    ap.add_argument("--recurrence", type=int,
                    help="frames backpropagated through the memory (default 4 with memory, 1 "
                    "without)")
    ap.add_argument("--out", required=True, help="directory for status.pt and log.csv")
    args = ap.parse_args()

    torch.manual_seed(args.seed)
    np.random.seed(args.seed)
    torch.set_num_threads(args.threads)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    envs = [gym.make(args.env) for _ in range(args.procs)]
    obss = [env.reset(seed=args.seed + 10000 * i)[0] for i, env in enumerate(envs)]
    vocab = Vocabulary(100)
    model = ACModel(
        {"image": (7, 7, 3), "text": 100}, envs[0].action_space, use_memory=args.mem,
        use_text=args.text,
    )
    opt = torch.optim.Adam(model.parameters(), 1e-3, eps=1e-8)
    P, T = args.procs, args.frames_per_proc
    R = args.recurrence or (4 if args.mem else 1)
    if R > 1 and not args.mem:
        raise SystemExit("error: --recurrence > 1 needs a memory (--mem)")
    gamma, lam, clip, ent_c, val_c, max_norm, epochs, batch = 0.99, 0.95, 0.2, 0.01, 0.5, 0.5, 4, 256

    memory = torch.zeros(P, model.memory_size)
    mask = torch.ones(P)
    returns = deque(maxlen=200)
    ep_return = np.zeros(P)
    frames, update, start = 0, 0, time.time()
    log = open(out / "log.csv", "w")
    log.write("update,frames,seconds,episodes,mean_return,success\n")
    while frames < args.frames:
        # --- collect T frames from each of the P environments (torch-ac's collect_experiences)
        b_obs, b_mem, b_mask, b_act, b_val, b_rew, b_logp = [], [], [], [], [], [], []
        for _ in range(T):
            pobs = preprocess(obss, vocab)
            with torch.no_grad():
                dist, value, new_mem = model(pobs, memory * mask.unsqueeze(1))
            action = dist.sample()
            rewards, dones = np.zeros(P), np.zeros(P)
            next_obss = []
            for i, env in enumerate(envs):
                o, r, term, trunc, _ = env.step(int(action[i]))
                ep_return[i] += r
                if term or trunc:
                    returns.append(ep_return[i])
                    ep_return[i] = 0.0
                    o, _ = env.reset()
                next_obss.append(o)
                rewards[i], dones[i] = r, term or trunc
            b_obs.append(pobs)
            b_mem.append(memory)
            b_mask.append(mask)
            b_act.append(action)
            b_val.append(value)
            b_rew.append(torch.tensor(rewards, dtype=torch.float))
            b_logp.append(dist.log_prob(action))
            obss, memory = next_obss, new_mem
            mask = 1 - torch.tensor(dones, dtype=torch.float)
        with torch.no_grad():
            _, next_value, _ = model(preprocess(obss, vocab), memory * mask.unsqueeze(1))
        adv = [None] * T
        nxt_adv, nxt_val, nxt_mask = torch.zeros(P), next_value, mask
        for t in reversed(range(T)):
            delta = b_rew[t] + gamma * nxt_val * nxt_mask - b_val[t]
            nxt_adv = delta + gamma * lam * nxt_adv * nxt_mask
            adv[t] = nxt_adv
            nxt_val, nxt_mask = b_val[t], b_mask[t]
        frames += P * T

        # --- flatten (process-major, as torch-ac) and pad missions to one length
        L = max(o.text.shape[1] for o in b_obs)
        image = torch.stack([o.image for o in b_obs], 1).reshape(P * T, 7, 7, 3)
        text = torch.stack([F.pad(o.text, (0, L - o.text.shape[1])) for o in b_obs], 1)
        text = text.reshape(P * T, L)
        mem = torch.stack(b_mem, 1).reshape(P * T, -1)
        msk = torch.stack(b_mask, 1).reshape(P * T)
        act = torch.stack(b_act, 1).reshape(-1)
        val = torch.stack(b_val, 1).reshape(-1)
        advs = torch.stack(adv, 1).reshape(-1)
        logp = torch.stack(b_logp, 1).reshape(-1)
        ret = val + advs

        # --- PPO update with recurrence R (torch-ac's PPOAlgo.update_parameters)
        for _ in range(epochs):
            starts = np.arange(0, P * T, R)
            starts = starts[np.random.permutation(len(starts))]
            per = batch // R
            for b in range(0, len(starts), per):
                inds = torch.tensor(starts[b : b + per])
                m = mem[inds]
                loss = 0.0
                for i in range(R):
                    sb = inds + i
                    dist, value, m = model(
                        SimpleNamespace(image=image[sb], text=text[sb]), m * msk[sb].unsqueeze(1)
                    )
                    entropy = dist.entropy().mean()
                    ratio = torch.exp(dist.log_prob(act[sb]) - logp[sb])
                    s1 = ratio * advs[sb]
                    s2 = torch.clamp(ratio, 1 - clip, 1 + clip) * advs[sb]
                    policy_loss = -torch.min(s1, s2).mean()
                    v_clip = val[sb] + torch.clamp(value - val[sb], -clip, clip)
                    value_loss = torch.max((value - ret[sb]) ** 2, (v_clip - ret[sb]) ** 2).mean()
                    loss = loss + policy_loss - ent_c * entropy + val_c * value_loss
                    if i < R - 1:
                        mem[sb + 1] = m.detach()
                loss = loss / R
                opt.zero_grad()
                loss.backward()
                torch.nn.utils.clip_grad_norm_(model.parameters(), max_norm)
                opt.step()
        update += 1
        if returns:
            mean_ret = float(np.mean(returns))
            success = float(np.mean([r > 0 for r in returns]))
            secs = time.time() - start
            log.write(f"{update},{frames},{secs:.1f},{len(returns)},{mean_ret:.4f},{success:.4f}\n")
            log.flush()
            if update % 10 == 0:
                print(f"U {update} F {frames} {frames / secs:.0f} fps return {mean_ret:.3f} "
                      f"success {success:.3f}", flush=True)
        torch.save(
            {"model_state": model.state_dict(), "vocab": dict(vocab.vocab),
             "num_frames": frames, "update": update},
            out / "status.pt.tmp",
        )
        (out / "status.pt.tmp").replace(out / "status.pt")
    return 0


if __name__ == "__main__":
    sys.exit(main())
