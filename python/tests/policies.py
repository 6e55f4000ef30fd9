"""Python policies for the evaluate/record tests."""

import re

import numpy as np

OBJECT_IDX = {"key": 5, "ball": 6, "box": 7}
COLOR_IDX = {"red": 0, "green": 1, "blue": 2, "purple": 3, "yellow": 4, "grey": 5}


def reactive_logits(image, direction):
    """A deterministic function of one observation that walks, turns at walls (and now and
    then in the open), picks up what it faces and opens doors: episodes end in varied ways,
    and replaying it on minigrid's observations must choose the same actions if evaluate fed
    it the right ones."""
    h = (int(image.astype(np.int64).sum()) * 31 + int(direction) * 7) % 10
    kind, _, state = image[3, 5]  # the cell in front of the agent
    if kind in (5, 6, 7):
        action = 3  # pick up
    elif kind == 4 and state != 0:
        action = 5  # open the door
    elif kind in (1, 4) and h > 1:
        action = 2  # forward
    else:
        action = h % 2  # turn
    logits = np.zeros(7, np.float32)
    logits[action] = 1.0
    return logits


def reactive(obs, first):
    return np.stack([reactive_logits(i, d) for i, d in zip(obs["image"], obs["direction"])])


def grounded(obs, first, layout="image"):
    """Forward-biased, with each object or colour word's map spread over the visible
    keys/balls/boxes it names (what the grounding accuracies count as related), in the
    axis order of ``image``; the other words get uniform maps and no weight."""
    n = len(obs["mission"])
    img = obs["image"]
    words = [re.findall("[a-z]+", m.lower()) for m in obs["mission"]]
    length = max(len(w) for w in words)
    maps = np.full((n, length, 7, 7), 1 / 49, np.float32)
    weights = np.zeros((n, length), np.float32)
    objects = np.isin(img[..., 0], list(OBJECT_IDX.values()))
    for i, ws in enumerate(words):
        for j, w in enumerate(ws):
            cells = None
            if w in OBJECT_IDX:
                cells = img[i, :, :, 0] == OBJECT_IDX[w]
            elif w in COLOR_IDX:
                cells = objects[i] & (img[i, :, :, 1] == COLOR_IDX[w])
            if cells is not None and cells.any():
                maps[i, j] = cells / cells.sum()
                weights[i, j] = 1.0
        if weights[i].sum() == 0:
            weights[i, : len(ws)] = 1.0
        weights[i] /= weights[i].sum()
    if layout == "agent-up":
        maps = maps.transpose(0, 1, 3, 2).copy()
    logits = np.zeros((n, 7), np.float32)
    logits[:, 2] = 1.0
    logits[:, 1] = 0.3
    return {"logits": logits, "word_maps": maps, "word_weights": weights}


def three_logits(image, direction):
    """An agent of MiniGrid's first three actions (left, right, forward: Dynamic-Obstacles'
    action space), as `reactive_logits`: walks where the cell ahead is empty or the goal,
    now and then walks into a wall (-1 on Dynamic-Obstacles), turns elsewhere. Its 3 logits."""
    h = (int(image.astype(np.int64).sum()) * 31 + int(direction) * 7) % 10
    kind = image[3, 5, 0]  # the cell in front of the agent
    if (kind in (1, 8) and h > 1) or (kind == 2 and h == 0):
        action = 2  # forward
    else:
        action = h % 2  # turn
    logits = np.zeros(3, np.float32)
    logits[action] = 1.0
    return logits


def three_actions(obs, first):
    """`three_logits` for every row: logits (N, 3)."""
    return np.stack([three_logits(i, d) for i, d in zip(obs["image"], obs["direction"])])
