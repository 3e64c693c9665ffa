# SPDX-License-Identifier: MIT
"""Generator of the 5x5 median selection network used in lib/src/pixel/median.c (`median_network()`), with its
exhaustive 0-1-principle check; vdtools.generators.median5_net builds the shared-pair block on it."""
import itertools


# ---------------------------------------------------------------------------
# Generator of the 5x5 median selection network in lib/src/pixel/median.c.
# A network is built symbolically from min/max nodes with constant folding
# (+inf padding) and common-subexpression sharing; only nodes that reach the
# wanted output are emitted. Correctness: a min/max circuit selects the k-th
# order statistic of all inputs iff it does so for all 0/1 inputs (0-1
# principle); with sorted input columns there are only 6^5 such inputs.

_INF, _NINF = "INF", "NINF"


class _Net:
    def __init__(self):
        self.nodes, self.order = {}, []

    def op(self, kind, a, b):
        if a == b:
            return a
        lo_id, hi_id = (_INF, _NINF) if kind == "min" else (_NINF, _INF)
        if a == lo_id:
            return b
        if b == lo_id:
            return a
        if hi_id in (a, b):
            return hi_id
        key = (kind,) + tuple(sorted((a, b)))
        if key not in self.nodes:
            self.nodes[key] = "n%d" % len(self.order)
            self.order.append(key)
        return self.nodes[key]

    def reachable(self, out):
        inv = {v: k for k, v in self.nodes.items()}
        need, stack = set(), [out]
        while stack:
            x = stack.pop()
            if x in need or x not in inv:
                continue
            need.add(x)
            stack += list(inv[x][1:])
        return [(k, self.nodes[k]) for k in self.order if self.nodes[k] in need]


def _oddeven_merge(lo, n, r, pairs):
    # Batcher's odd-even merge of wires lo..lo+n-1 (n a power of two), iterative form
    # of the usual recursion, unrolled by an explicit stack.
    stack = [(lo, n, r, 0)]
    while stack:
        lo, n, r, phase = stack.pop()
        step = r * 2
        if step >= n:
            pairs.append((lo, lo + r))
        elif phase == 0:
            stack.append((lo, n, r, 1))
            stack.append((lo + r, n, step, 0))
            stack.append((lo, n, step, 0))
        else:
            pairs.extend((i, i + r) for i in range(lo + r, lo + n - r, step))


def _merge_sorted(net, a, b):
    m = 1
    while m < max(len(a), len(b)):
        m *= 2
    w = list(a) + [_INF] * (m - len(a)) + list(b) + [_INF] * (m - len(b))
    pairs = []
    _oddeven_merge(0, 2 * m, 1, pairs)
    for i, j in pairs:
        x, y = w[i], w[j]
        w[i], w[j] = net.op("min", x, y), net.op("max", x, y)
    return w[:len(a) + len(b)]


def _kth(net, a, b, k):
    """k-th smallest (1-based) of sorted a u sorted b = min over i+j=k of max(a_i, b_j)."""
    best = None
    for i in range(k + 1):
        j = k - i
        if i > len(a) or j > len(b):
            continue
        m = net.op("max", a[i - 1] if i else _NINF, b[j - 1] if j else _NINF)
        best = m if best is None else net.op("min", best, m)
    return best


def _emit(net, outs, names, indent):
    need = set()
    for o, _ in outs:
        need.update(nm for _, nm in net.reachable(o))
    local, lines = {}, []
    for key in net.order:
        nm = net.nodes[key]
        if nm not in need:
            continue
        kind, a, b = key
        local[nm] = "t%d" % len(local)
        ref = lambda x: names.get(x, local.get(x, x))  # noqa: E731
        lines.append("%sconst uint8_t %s = %s(%s, %s);" % (indent, local[nm], "VD_MIN8" if kind == "min" else "VD_MAX8",
                                                            ref(a), ref(b)))
    for o, target in outs:
        lines.append("%s%s = %s;" % (indent, target, names.get(o, local.get(o, o))))
    return lines


def median_network(check=True):
    """C statements of the two generated blocks of median.c: (pair_lines, select_lines).

    pair: sorted columns a0..a4, b0..b4 -> pr[0..9][i] (Batcher merge, 26 min/max).
    select: p0..p9, q0..q9 (two sorted pairs), c0..c4 (a sorted column) -> out[i], the
    13th smallest of the 25. With check=True both are verified on every 0/1 input."""
    pnet = _Net()
    a = ["a%d" % r for r in range(5)]
    b = ["b%d" % r for r in range(5)]
    merged = _merge_sorted(pnet, a, b)
    pair_lines = _emit(pnet, [(merged[k], "pr[%d][i]" % k) for k in range(10)], {}, " " * 4)

    snet = _Net()
    p = ["p%d" % r for r in range(10)]
    q = ["q%d" % r for r in range(10)]
    c = ["c%d" % r for r in range(5)]
    qc = _merge_sorted(snet, q, c)
    out = _kth(snet, p, qc, 13)
    select_lines = _emit(snet, [(out, "out[i]")], {}, " " * 16)

    if check:
        def run(net, target, env):
            for (kind, x, y), nm in net.reachable(target):
                env[nm] = min(env[x], env[y]) if kind == "min" else max(env[x], env[y])
            return env.get(target)
        for zeros in itertools.product(range(6), repeat=2):  # pair merge: counts of zeros per column
            env = {}
            cols = [[int(r >= z) for r in range(5)] for z in zeros]
            env.update({"a%d" % r: cols[0][r] for r in range(5)})
            env.update({"b%d" % r: cols[1][r] for r in range(5)})
            want = sorted(cols[0] + cols[1])
            for k in range(10):
                assert run(pnet, merged[k], dict(env)) == want[k], "pair merge network is wrong"
        for zeros in itertools.product(range(6), repeat=5):
            cols = [[int(r >= z) for r in range(5)] for z in zeros]
            pv, qv = sorted(cols[0] + cols[1]), sorted(cols[2] + cols[3])
            env = {"p%d" % r: pv[r] for r in range(10)}
            env.update({"q%d" % r: qv[r] for r in range(10)})
            env.update({"c%d" % r: cols[4][r] for r in range(5)})
            assert run(snet, out, env) == sorted(sum(cols, []))[12], "select network is wrong"
    return pair_lines, select_lines
