# SPDX-License-Identifier: MIT
"""Shallow baselines of paper 001's Table 1 and paper 003's comparison, on the same 32x32 samples:

  HOG + linear SVM   skimage hog: 9 orientations, 8x8-pixel cells, 2x2-cell blocks (L2-Hys) on the
                     32x32 sample -> 324 values; sklearn LinearSVC, C picked on the val split.
  Haar + AdaBoost    the sample downscaled to 16x16 (area average); skimage haar_like_feature on its
                     integral image with a fixed random subset of HAAR_N of all five feature types
                     (the full 16x16 set has 32,384 features; seed 0); AdaBoost (SAMME) of decision stumps.
  LBP + AdaBoost     skimage local_binary_pattern P=8, R=1, 'uniform' (10 codes) histograms over a 4x4
                     grid of 8x8 cells -> 160 values; AdaBoost of decision stumps.
Scores: SVM decision value, AdaBoost probability of "vehicle" (threshold 0 / 0.5 for the table,
all scores for the DET curve).
"""
import numpy as np
from skimage.feature import haar_like_feature, haar_like_feature_coord, hog, local_binary_pattern
from skimage.transform import integral_image

HAAR_SIZE = 16
HAAR_N = 500
HAAR_TYPES = ("type-2-x", "type-2-y", "type-3-x", "type-3-y", "type-4")
ADA_ESTIMATORS = 150


def hog_features(X):
    return np.array([hog(x, orientations=9, pixels_per_cell=(8, 8), cells_per_block=(2, 2),
                         block_norm="L2-Hys") for x in X], np.float32)


def lbp_features(X):
    out = np.empty((len(X), 16 * 10), np.float32)
    for k, x in enumerate(X):
        codes = local_binary_pattern(x, 8, 1, "uniform").astype(np.int64)  # 0..9
        cells = codes.reshape(4, 8, 4, 8).transpose(0, 2, 1, 3).reshape(16, 64)
        h = np.stack([np.bincount(c, minlength=10) for c in cells]).astype(np.float32) / 64.0
        out[k] = h.reshape(-1)
    return out


def haar_coords(seed=0, n=HAAR_N):
    coords, types = [], []
    for t in HAAR_TYPES:
        c, ty = haar_like_feature_coord(HAAR_SIZE, HAAR_SIZE, t)
        coords.append(c)
        types.append(ty)
    coords = np.concatenate(coords)
    types = np.concatenate(types)
    pick = np.sort(np.random.default_rng(seed).choice(len(coords), n, replace=False))
    return coords[pick], types[pick], len(coords)


def haar_features(X, coords, types):
    import cv2
    out = np.empty((len(X), len(coords)), np.float32)
    for k, x in enumerate(X):
        small = cv2.resize(x, (HAAR_SIZE, HAAR_SIZE), interpolation=cv2.INTER_AREA).astype(np.float64) / 255.0
        ii = integral_image(small)
        out[k] = haar_like_feature(ii, 0, 0, HAAR_SIZE, HAAR_SIZE, feature_type=types, feature_coord=coords)
    return out


def _adaboost(seed):
    from sklearn.ensemble import AdaBoostClassifier
    from sklearn.tree import DecisionTreeClassifier
    stump = DecisionTreeClassifier(max_depth=1)
    try:
        return AdaBoostClassifier(estimator=stump, n_estimators=ADA_ESTIMATORS, random_state=seed)
    except TypeError:  # scikit-learn < 1.2
        return AdaBoostClassifier(base_estimator=stump, n_estimators=ADA_ESTIMATORS, random_state=seed)


def run_all(X, y, split, seed=0, log=print):
    """Trains the three baselines on split=='train' (val for the SVM's C). Returns
    {name: {"score": test scores, "threshold": t, "params": {...}}} for the test rows."""
    from sklearn.svm import LinearSVC
    tr, va, te = (split == s for s in ("train", "val", "test"))
    res = {}

    F = hog_features(X)
    best = None
    for C in (0.01, 0.1, 1.0):
        clf = LinearSVC(C=C, dual=False, max_iter=5000).fit(F[tr], y[tr])
        acc = float(np.mean(clf.predict(F[va]) == y[va]))
        if best is None or acc > best[0]:
            best = (acc, C, clf)
    res["HOG + linear SVM"] = {"score": best[2].decision_function(F[te]), "threshold": 0.0,
                               "params": {"features": int(F.shape[1]), "C": best[1], "val_acc": best[0]}}
    if log:
        log(f"  HOG + SVM: {F.shape[1]} features, C={best[1]} (val acc {best[0]:.4f})")

    coords, types, n_all = haar_coords(seed)
    F = haar_features(X, coords, types)
    ada = _adaboost(seed).fit(F[tr], y[tr])
    res["Haar + AdaBoost"] = {"score": ada.predict_proba(F[te])[:, 1], "threshold": 0.5,
                              "params": {"features": int(F.shape[1]), "of": int(n_all), "size": HAAR_SIZE,
                                         "stumps": ADA_ESTIMATORS,
                                         "val_acc": float(np.mean(ada.predict(F[va]) == y[va]))}}
    if log:
        log(f"  Haar + AdaBoost: {F.shape[1]} of {n_all} features on {HAAR_SIZE}x{HAAR_SIZE}")

    F = lbp_features(X)
    ada = _adaboost(seed).fit(F[tr], y[tr])
    res["LBP + AdaBoost"] = {"score": ada.predict_proba(F[te])[:, 1], "threshold": 0.5,
                             "params": {"features": int(F.shape[1]), "stumps": ADA_ESTIMATORS,
                                        "val_acc": float(np.mean(ada.predict(F[va]) == y[va]))}}
    if log:
        log(f"  LBP + AdaBoost: {F.shape[1]} features")
    return res
