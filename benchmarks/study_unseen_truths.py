"""Study: does k_TB hold on bearing-rig truths the project has never seen?

An independent truth generator: it imports nothing from ema_rig (neither ``ema_rig.simulate`` nor
``tests/rig_truth.py``). A lumped mass-spring-damper model of the rig is written out here from the
paper's Table 1 and its Fig. 6 topology (DESIGN section 4: ground -k_B- m_F; m_F -k_AS- m_H;
m_F -k_S- m_S; m_S -k_TB+MS- m_H, k_TB+MS = k_TB and k_MS in series; force on m_H), extended by
what the 3DOF model does not have and a real rig shows:

* the housing's lateral (z) and axial (x) translations on their own springs, and the spindle's
  axial translation, weakly coupled to the radial chain (so the 14+Z, 15+X and 23+X sensors see
  real modes, not noise);
* optionally a flexible frame part m_P on k_P between the frame and the air springs (k_AS ends on
  m_P instead of the rigid frame), its own frequency (housing held) tuned 1-3 % from the housing
  mode, so that the housing mode and a frame mode couple through the air springs;
* accelerometer masses on each of the five housing sensors (a rigid housing: each adds its mass
  to the housing's three translations);
* the housing mass off the rig file's nominal;
* a viscous bearing dashpot c_TB across the bearing (heavier damping) plus light proportional
  damping of the structure;
* a steel-disk truth (k_TB infinite) from which ``ema-rig calibrate`` gives the k_MS that the
  stiffness run's rig file then holds.

M, K, C are assembled, the accelerances at the eight sensor DOFs are solved exactly at every line
(-w^2 (K - w^2 M + j w C)^-1 f), complex noise is added, the file is written by pyuff (UFF58,
sensor 13 mounted along -Y) and the CLI runs at its defaults (``python -m ema_rig.cli stiffness
FILE --rig R --json OUT``). Per truth: k_TB true vs printed, the stated sigma and its parts,
z = error / sigma, warnings, exit code.

Usage::

    nice -n 19 python benchmarks/study_unseen_truths.py [--seeds N] [--seed-offset S] [--only SUBSTRING] [-o FILE]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import subprocess
import sys
import tempfile
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

ROOT = Path(__file__).resolve().parents[1]
TREE = [ROOT]  # the ema_rig checkout the CLI runs from (--tree)
TIGHT = dict.fromkeys(("m_H", "m_S", "m_F", "k_MS", "k_AS", "k_S", "k_B"), 1e-4)
FREQ = np.arange(0.0, 1100.25, 0.5)  # Hz, the bundled files' grid
N_SEEDS = [6]
SEED_OFFSET = [0]  # first seed (--seed-offset): 0 reproduces the runs the rules were developed on

TABLE1 = {"m_H": 2.566, "m_S": 2.8, "m_F": 205.0, "k_MS": 114e6, "k_AS": 650e3, "k_S": 348e6, "k_B": 180e3}
TOL = {"m_H": 0.005, "m_S": 0.02, "m_F": 0.05, "k_MS": 0.02, "k_AS": 0.10, "k_S": 0.02, "k_B": 0.10}
SENSORS = (("11+Y", "housing", "radial"), ("12+Y", "housing", "radial"), ("13-Y", "housing", "radial"),
           ("14+Z", "housing", "lateral"), ("15+X", "housing", "axial"), ("21+Y", "spindle", "radial"),
           ("22+Y", "spindle", "radial"), ("23+X", "spindle", "axial"))

# DOF indices of the lumped model
YH, YS, YF, ZH, XH, XS, QP, ZS, QS = range(9)  # ZS, QS only in the 9-DOF truths (r_truth13)


@dataclass(frozen=True)
class Truth:
    """One rig truth (SI units)."""

    k_TB: float
    k_MS: float = TABLE1["k_MS"]
    m_H: float = TABLE1["m_H"]  # the true housing mass (without the sensor masses)
    sensor_mass: float = 0.0  # kg on each of the five housing sensors
    declare_sensor_mass: bool = True
    file_m_H: float = TABLE1["m_H"]  # what the rig file states
    file_tol: dict[str, float] = field(default_factory=dict)  # overrides of the rig file's [uncertainty]
    frame_ratio: float | None = None  # flexible frame part's own frequency / housing mode (None: absent)
    m_P: float = 5.0  # kg, modal mass of the frame mode where the air springs' arm meets it
    zeta_H: float = 0.01  # bearing dashpot as a damping ratio of the housing on k_TB+MS
    bearing_loss: float = 0.0  # hysteretic (structural) loss factor eta of the bearing: k_TB (1 + j eta)
    support_zeta: float = 0.0  # dashpot across the air springs (housing - frame) as a damping ratio on k_TB+MS
    spindle_sensor_mass: float = 0.0  # kg on each of the three spindle sensors (never declared)
    lat_freq: float = 430.0  # Hz, housing lateral translation
    ax_freq: float = 310.0  # Hz, housing axial translation (paper: near 300 Hz)
    sp_ax_freq: float = 1012.0  # Hz, spindle axial (paper Sect. 3)
    noise: float = 0.01  # relative complex noise on every line
    structure_zeta: float = 0.003  # stiffness-proportional damping of the structure (zeta at 600 Hz), k_S's too
    mass_scale: float = 1.0  # another rig: Table 1's masses (and the axial spindle mass) times this
    stiff_scale: float = 1.0  # ... and Table 1's stiffnesses times this (the rig file states the scaled values)
    seed: int = 0
    # r_truth12: a second housing mode near the radial one with another shape (ovalisation-like: the
    # driving point against the other two radial sensors), an independent modal term of its own mass at
    # the driving point, observed and forced (reciprocity) through the same pattern
    second_ratio: float | None = None  # its frequency / the housing mode's (None: absent)
    second_mass: float = 10.0  # kg, its modal mass at the driving point (pattern 1 there)
    second_zeta: float = 0.01
    second_shape: tuple[float, ...] = (1.0, -0.8, -0.8, 0.15, 0.1, 0.05, 0.05, 0.02)  # per sensor, physical +axis
    # r_truth13 (seeds 60+): physics none of the families above has
    aniso_delta: float = 0.0  # anisotropic bearing: k_2 / k_1 - 1 of the principal stiffnesses (0: isotropic)
    aniso_deg: float = 0.0  # angle of the principal axis k_1 from the radial (load, Y) direction, degrees
    tilt: tuple[tuple[int, int, float], ...] = ()  # (sensor index, DOF it leans towards, degrees off its axis)
    df: float = 0.5  # Hz, line spacing of the measurement
    band: tuple[float, float] | None = None  # the rig file's [identification] band (None: 150-1000 Hz scaled)
    shaker_mass: float = 0.0  # kg, armature + stinger behind the force gauge (0: an ideal force, no drop-out)
    shaker_c: float = 0.0  # N s/m, the voltage-driven shaker's back-EMF damping (Bl)^2 / R
    force_noise: float = 0.03  # force gauge noise relative to the electrical force's level (shaker truths)
    n_avg: int = 30  # averages of the H1 estimate (shaker truths)
    second_ref: bool = False  # a second shaker on 15+X; its FRFs in the file too, the rig file names one
    spindle_ratio: float | None = None  # spindle bending mode (y_S held... on y_S) / housing mode (None: absent)
    spindle_mass: float = 1.0  # kg, its modal mass (on a spring to y_S; 22+Y reads it)
    rig_flip: tuple[str, ...] = ()  # sensors whose sign the rig file states reversed (the file's DOF as mounted)
    hann: bool = False  # the lines are a Hann-windowed random test's expected H1 (leakage), record 1 / df

    @property
    def table(self) -> dict[str, float]:
        """Table 1 of this rig (scaled masses and stiffnesses; k_MS is the truth's own field)."""
        out = {key: val * (self.mass_scale if key.startswith("m_") else self.stiff_scale)
               for key, val in TABLE1.items()}
        out["k_MS"] = self.k_MS
        return out

    @property
    def freq(self) -> NDArray[np.float64]:
        """The measurement's lines, Hz (the bundled files' 0.5 Hz grid unless ``df`` says otherwise)."""
        return FREQ if self.df == 0.5 else np.arange(0.0, 1100.0 + self.df / 2, self.df)

    @property
    def n_dof(self) -> int:
        """7, or 9 with the spindle's lateral translation (anisotropic bearing) and its bending mode."""
        return 9 if (self.aniso_delta or self.spindle_ratio is not None) else 7

    @property
    def freq_scale(self) -> float:
        return math.sqrt(self.stiff_scale / self.mass_scale)

    @property
    def k_TB_MS(self) -> float:
        return 1.0 / (1.0 / self.k_TB + 1.0 / self.k_MS) if math.isfinite(self.k_TB) else self.k_MS

    @property
    def m_H_total(self) -> float:
        return self.m_H + 5 * self.sensor_mass

    def matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """M, K, C (7 x 7); the flexible frame DOF is stiff and massless-free when absent."""
        p = self.table
        m_xs = 1.5 * self.mass_scale
        n = self.n_dof
        m = np.zeros((n, n))
        k = np.zeros((n, n))
        c = np.zeros((n, n))

        def spring(a: int, b: int | None, kv: float, mat: NDArray[np.float64]) -> None:
            mat[a, a] += kv
            if b is not None:
                mat[b, b] += kv
                mat[a, b] -= kv
                mat[b, a] -= kv

        mh = self.m_H_total
        ms = 3 * self.spindle_sensor_mass  # the spindle is rigid: its three sensors ride on y_S and x_S
        for i, mv in ((YH, mh), (YS, p["m_S"] + ms), (YF, p["m_F"]), (ZH, mh), (XH, mh), (XS, m_xs + ms),
                      (QP, self.m_P)):
            m[i, i] = mv
        if n > 7:  # the spindle's lateral translation (its radial mass) and a bending mode on y_S
            m[ZS, ZS] = p["m_S"] + ms
            m[QS, QS] = self.spindle_mass
            spring(ZS, None, p["k_S"], k)  # the spindle's bending stiffness laterally (the frame held)
            if self.spindle_ratio is not None:
                spring(QS, YS, self.spindle_mass * (2 * math.pi * self._housing_freq_3dof() * self.spindle_ratio) ** 2, k)
            else:
                spring(QS, None, 1.0, k)
        k_tbms = self.k_TB_MS
        spring(YF, None, p["k_B"], k)
        spring(YF, YS, p["k_S"], k)
        if self.frame_ratio is None:  # the air springs act on the rigid frame; QP idles on its own spring
            spring(YF, YH, p["k_AS"], k)
            spring(QP, None, self.m_P * (2 * math.pi * 1500.0) ** 2, k)
        else:  # the air springs' reaction goes into a flexible frame part m_P on k_P
            w2 = (2 * math.pi * self._housing_freq_3dof() * self.frame_ratio) ** 2
            spring(YF, QP, w2 * self.m_P - p["k_AS"], k)  # frame mode (housing held) at frame_ratio x f_H
            spring(QP, YH, p["k_AS"], k)
        if self.aniso_delta:  # the housing's lateral motion rides on the bearing (below) and the air springs
            spring(ZH, None, p["k_AS"], k)
        else:
            spring(ZH, None, mh * (2 * math.pi * self.lat_freq) ** 2, k)
        k_ax = mh * (2 * math.pi * self.ax_freq) ** 2
        spring(XH, XS, k_ax, k)
        spring(XS, None, m_xs * (2 * math.pi * self.sp_ax_freq) ** 2, k)
        # weak elastic cross-coupling (3 %) of the bearing's radial deflection y_H - y_S with the
        # housing's lateral and axial motion (a rigid translation of the rig stays force-free)
        e = np.zeros(n)
        e[YH], e[YS] = 1.0, -1.0
        for a, kb in (((XH, k[XH, XH]),) if self.aniso_delta else ((ZH, k[ZH, ZH]), (XH, k[XH, XH]))):
            kc = 0.03 * math.sqrt(k_tbms * kb)
            u = np.zeros(n)
            u[a] = 1.0
            k += kc * (np.outer(e, u) + np.outer(u, e))
        # light stiffness-proportional damping of the structure (0.3 % at 600 Hz); the bearing element
        # (k_TB + j w c_TB in series with k_MS) is added per line in frf()
        c += self.structure_zeta / (math.pi * 600.0) * k
        if self.support_zeta > 0:  # damping in the housing's support: a dashpot beside the air springs
            spring(YH, QP if self.frame_ratio is not None else YF,
                   2 * self.support_zeta * math.sqrt(self.k_TB_MS * self.m_H_total), c)
        return m, k, c

    @property
    def c_TB(self) -> float:
        """Bearing dashpot [N s/m] in parallel with k_TB that gives the housing mode about zeta_H."""
        if not math.isfinite(self.k_TB):
            return 0.0
        return 2 * self.zeta_H * math.sqrt(self.k_TB_MS * self.m_H_total) / (self.k_TB_MS / self.k_TB) ** 2

    def bearing(self, om: float) -> complex:
        """Dynamic stiffness [N/m] of the bearing element between housing and spindle."""
        if not math.isfinite(self.k_TB):
            return complex(self.k_MS)
        return 1.0 / (1.0 / (self.k_TB * (1 + 1j * self.bearing_loss) + 1j * om * self.c_TB) + 1.0 / self.k_MS)

    def _housing_freq_3dof(self) -> float:
        """The housing mode of the 3DOF model (without the frame part), Hz."""
        p = self.table
        m = np.diag([self.m_H_total, p["m_S"], p["m_F"]])
        k = np.array([[p["k_AS"] + self.k_TB_MS, -self.k_TB_MS, -p["k_AS"]],
                      [-self.k_TB_MS, self.k_TB_MS + p["k_S"], -p["k_S"]],
                      [-p["k_AS"], -p["k_S"], p["k_AS"] + p["k_S"] + p["k_B"]]])
        lam = np.sort(np.linalg.eigvals(np.linalg.solve(m, k)).real)
        return float(math.sqrt(lam[1]) / (2 * math.pi))

    def frf(self, freq: NDArray[np.float64]) -> NDArray[np.complex128]:
        """Accelerance [m/s^2/N] at the eight sensors (sign as mounted), shape (8, n_freq); with
        ``second_ref`` shape (16, n_freq), the axial shaker's eight after the radial one's."""
        h = self._leaked(freq) if self.hann else self._frf_exact(freq)
        if self.shaker_mass > 0:
            return self._h1(freq, h)[0]
        rng = np.random.default_rng(self.seed)
        out = h[:8]
        scale = self.noise * (np.abs(out) + 1e-3 * np.abs(out).max(axis=1, keepdims=True)) / math.sqrt(2)
        out += scale * (rng.standard_normal(out.shape) + 1j * rng.standard_normal(out.shape))
        if h.shape[0] > 8:  # the second reference's noise after the first's (the first unchanged)
            o2 = h[8:]
            scale = self.noise * (np.abs(o2) + 1e-3 * np.abs(o2).max(axis=1, keepdims=True)) / math.sqrt(2)
            o2 += scale * (rng.standard_normal(o2.shape) + 1j * rng.standard_normal(o2.shape))
        return h

    def _leaked(self, freq: NDArray[np.float64]) -> NDArray[np.complex128]:
        """Expected H1 of a Hann-windowed random test with records of 1 / df s: the true FRF averaged
        over the window's spectral power |W(f - nu)|^2 (white excitation; Bendat & Piersol, Random Data,
        sect. 11.5: leakage), on a grid of df / 16 over +-8 lines; H(-nu) = conj H(nu)."""
        df = float(freq[1] - freq[0])
        sub = 16
        nu = np.arange(-8 * sub, (freq.size - 1) * sub + 8 * sub + 1) * (df / sub)
        h_pos = self._frf_exact(np.abs(nu))
        h_fine = np.where(nu < 0, np.conj(h_pos), h_pos)
        x = np.arange(-8 * sub, 8 * sub + 1) / sub  # offset in lines
        w = np.sinc(x) + 0.5 * np.sinc(x - 1) + 0.5 * np.sinc(x + 1)  # Hann window's spectrum (T = 1 / df)
        w2 = w**2 / (w**2).sum()
        out = np.empty((h_fine.shape[0], freq.size), dtype=complex)
        for i in range(freq.size):
            out[:, i] = h_fine[:, i * sub: i * sub + x.size] @ w2
        return out

    def coherence(self, freq: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """Ordinary coherence of the H1 estimate (shaker truths), shape (8, n_freq); else None."""
        return self._h1(freq, self._frf_exact(freq))[1] if self.shaker_mass > 0 else None

    def force_ratio(self, freq: NDArray[np.float64]) -> NDArray[np.complex128]:
        """Force into the structure / the shaker's electrical force: 1 / (1 + Z_a Y_dp), shape (n_freq,).

        A voltage-driven shaker (armature and stinger ``shaker_mass``, back-EMF damping ``shaker_c``)
        pushing the driving point through a stiff stinger: its impedance Z_a = c_e + j w m_a loads
        the structure's driving-point mobility Y_dp = A_dp / (j w), so the force drops at resonance
        (McConnell & Varoto, Vibration Testing, ch. 8: the force drop-out)."""
        h = self._frf_exact(freq)[0]
        om = 2 * math.pi * freq
        mob = np.zeros_like(h)
        nz = om > 0
        mob[nz] = h[nz] / (1j * om[nz])
        return 1.0 / (1.0 + (self.shaker_c + 1j * om * self.shaker_mass) * mob)

    def _h1(self, freq: NDArray[np.float64], h: NDArray[np.complex128]
            ) -> tuple[NDArray[np.complex128], NDArray[np.float64]]:
        """H1 = S_xf / S_ff over ``n_avg`` random-excitation averages and its coherence, shape (8, n_freq) each.

        Per average and line: electrical force F_e ~ CN(0, 1), force into the structure F = g F_e
        (:meth:`force_ratio`), gauge reading F + n_f (n_f ~ CN(0, force_noise^2)), responses
        A F + n_o (n_o ~ CN(0, (0.1 noise max|A_o|)^2): a floor 60 dB under the channel's peak at 1 %)."""
        rng = np.random.default_rng(self.seed)
        g = self.force_ratio(freq)
        a = h[:8]
        na = self.n_avg

        def cn(shape: tuple[int, ...]) -> NDArray[np.complex128]:
            return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / math.sqrt(2)

        fe = cn((na, freq.size))
        f_true = g * fe
        f_meas = f_true + self.force_noise * cn((na, freq.size))
        floor = 0.1 * self.noise * np.abs(a).max(axis=1, keepdims=True)
        x = a[None, :, :] * f_true[:, None, :] + floor[None] * cn((na, 8, freq.size))
        sxf = (x * np.conj(f_meas)[:, None, :]).sum(axis=0)
        sff = (np.abs(f_meas) ** 2).sum(axis=0)
        sxx = (np.abs(x) ** 2).sum(axis=0)
        h1 = sxf / sff
        coh = np.abs(sxf) ** 2 / np.maximum(sxx * sff, 1e-300)
        return h1, np.clip(coh, 0.0, 1.0)

    def bearing_2d(self, om: float) -> NDArray[np.complex128]:
        """Anisotropic bearing (principal k_1, k_2 = k_1 (1 + aniso_delta), k_1's axis aniso_deg off Y),
        with its dashpot (isotropic) and loss, in series with an isotropic k_MS: 2 x 2 over (y, z) [N/m].
        k_1 is chosen so that the bearing's Y-Y stiffness k_1 cos^2 + k_2 sin^2 is the truth's k_TB."""
        th = math.radians(self.aniso_deg)
        k1 = self.k_TB / (1 + self.aniso_delta * math.sin(th) ** 2)
        rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        kb = rot @ np.diag([k1, k1 * (1 + self.aniso_delta)]) @ rot.T * (1 + 1j * self.bearing_loss)
        kb = kb + 1j * om * self.c_TB * np.eye(2)
        return np.linalg.inv(np.linalg.inv(kb) + np.eye(2) / self.k_MS)

    def _obs(self) -> tuple[list[int], NDArray[np.float64]]:
        """Observed DOF per sensor and the (8, n_dof) observation matrix (sign as mounted, tilts)."""
        obs = [YH, YH, YH, ZH, XH, YS, QS if self.spindle_ratio is not None else YS, XS]
        sign = np.array([1, 1, -1, 1, 1, 1, 1, 1], dtype=float)
        c = np.zeros((8, self.n_dof))
        for s, i in enumerate(obs):
            c[s, i] = sign[s]
        for s, towards, deg in self.tilt:  # the sensor leans deg off its axis towards another DOF
            c[s] *= math.cos(math.radians(deg))
            c[s, towards] += math.sin(math.radians(deg))
        return obs, c

    def _frf_exact(self, freq: NDArray[np.float64]) -> NDArray[np.complex128]:
        """Noise-free accelerance, shape (8 or 16, n_freq) (see :meth:`frf`)."""
        m, k, c = self.matrices()
        n = self.n_dof
        obs, cobs = self._obs()
        sign = np.array([1, 1, -1, 1, 1, 1, 1, 1], dtype=float)
        plain = n == 7 and not self.tilt and not self.second_ref and self.spindle_ratio is None
        out = np.zeros((16 if self.second_ref else 8, freq.size), dtype=complex)
        f = np.zeros((n, 2))
        f[YH, 0] = 1.0
        f[XH, 1] = 1.0  # the second shaker, along 15+X
        e = np.zeros(n)
        e[YH], e[YS] = 1.0, -1.0
        ee = np.outer(e, e)
        ebig = np.zeros((2, n))
        ebig[0, YH], ebig[0, YS] = 1.0, -1.0
        if n > 7:
            ebig[1, ZH], ebig[1, ZS] = 1.0, -1.0
        for i, fr in enumerate(freq):
            om = 2 * math.pi * fr
            if plain:
                x = np.linalg.solve(k - om**2 * m + 1j * om * c + self.bearing(om) * ee, f[:, 0])
                out[:, i] = -(om**2) * x[list(obs)] * sign
                continue
            if self.aniso_delta:
                kb = ebig.T @ self.bearing_2d(om) @ ebig
            else:
                kb = self.bearing(om) * ee
            x2 = np.linalg.solve(k - om**2 * m + 1j * om * c + kb, f)
            out[:8, i] = -(om**2) * (cobs @ x2[:, 0])
            if self.second_ref:
                out[8:, i] = -(om**2) * (cobs @ x2[:, 1])
        if self.second_ratio is not None:
            w2 = 2 * math.pi * self._housing_freq_3dof() * self.second_ratio
            om = 2 * math.pi * freq
            shape = np.asarray(self.second_shape) * sign  # the pattern along each sensor's positive axis
            q = -(om**2) / (self.second_mass * (w2**2 - om**2 + 2j * self.second_zeta * w2 * om))
            out[:8] += np.outer(shape * shape[0], q)
        return out

    def rig_text(self, k_MS: float | None = None, k_MS_rel: float | None = None) -> str:
        params = dict(self.table, m_H=self.file_m_H)
        if k_MS is not None:
            params["k_MS"] = k_MS
        tol = dict(TOL, **self.file_tol)
        if k_MS_rel is not None:
            tol["k_MS"] = k_MS_rel
        text = "[rig]\nname = \"unseen truth\"\n\n[model]\n"
        text += "".join(f"{key} = {val!r}\n" for key, val in params.items())
        text += '\n[excitation]\nradial = "11+Y"\n\n[uncertainty]\n'
        text += "".join(f"{key} = {val!r}\n" for key, val in tol.items())
        fs = self.freq_scale  # the rig's modes move with sqrt(k/m): so does its band (inside the file's grid)
        lo, hi = self.band if self.band is not None else (150.0 * fs, min(1000.0 * fs, 1050.0))
        text += (f"\n[identification]\nband = [{lo:.1f}, {hi:.1f}]\n"
                 f"k_MS_band = [{min(700.0 * fs, 900.0):.1f}, 1100.0]\n")
        for dof, role, axis in SENSORS:
            if dof in self.rig_flip:
                dof = dof[:2] + ("+" if dof[2] == "-" else "-") + dof[3:]
            text += f'\n[[sensor]]\ndof = "{dof}"\nrole = "{role}"\naxis = "{axis}"\n'
            if role == "housing" and self.sensor_mass > 0 and self.declare_sensor_mass:
                text += f"mass = {self.sensor_mass!r}\n"
        return text


def write_uff(path: Path, freq: NDArray[np.float64], frf: NDArray[np.complex128],
              coherence: NDArray[np.float64] | None = None, n_avg: int = 0) -> None:
    """UFF58 of the accelerances (rows 8-15, when given, for the second reference 15+X) and, when
    given, their coherence (function type 6; the id line says the number of averages)."""
    import pyuff

    dirs = {"X": 1, "Y": 2, "Z": 3}
    sets = []
    refs = [(11, 2), (15, 1)]
    for row, h in enumerate(frf):
        dof = SENSORS[row % 8][0]
        ref_node, ref_dir = refs[row // 8]
        node, sgn, axis = int(dof[:2]), (-1 if dof[2] == "-" else 1), dof[3]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sets.append(pyuff.prepare_58(
                binary=0, func_type=4, rsp_node=node, rsp_dir=sgn * dirs[axis], ref_node=ref_node, ref_dir=ref_dir,
                ord_data_type=6, abscissa_spacing=1, abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
                ordinate_spec_data_type=12, ordinate_axis_units_lab="m/s^2", orddenom_spec_data_type=13,
                orddenom_axis_units_lab="N", data=h, x=freq, id1="unseen_truth",
                id2=f"Averages: {n_avg}" if n_avg else "NONE", id3="NONE", id4="NONE", id5="NONE"))
    for row, g in enumerate(coherence if coherence is not None else []):
        dof = SENSORS[row][0]
        node, sgn, axis = int(dof[:2]), (-1 if dof[2] == "-" else 1), dof[3]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sets.append(pyuff.prepare_58(
                binary=0, func_type=6, rsp_node=node, rsp_dir=sgn * dirs[axis], ref_node=11, ref_dir=2,
                ord_data_type=4, abscissa_spacing=1, abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
                ordinate_spec_data_type=0, ordinate_axis_units_lab="NONE", orddenom_spec_data_type=0,
                orddenom_axis_units_lab="NONE", data=g.astype(float), x=freq, id1="unseen_truth coherence",
                id2=f"Averages: {n_avg}", id3="NONE", id4="NONE", id5="NONE"))
    with contextlib.redirect_stdout(io.StringIO()):
        pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")


def cli(*args: str) -> tuple[int, dict[str, object] | None, str]:
    out = Path(tempfile.mkstemp(suffix=".json")[1])
    env = dict(os.environ, PYTHONPATH=str(TREE[0]))
    r = subprocess.run([sys.executable, "-m", "ema_rig.cli", *args, "--json", str(out)],
                       capture_output=True, text=True, env=env, cwd=TREE[0], check=False)
    res = json.loads(out.read_text()) if r.returncode == 0 and out.stat().st_size else None
    out.unlink()
    return r.returncode, res, r.stderr.strip().splitlines()[-1] if r.stderr.strip() else ""


@dataclass(frozen=True)
class Row:
    family: str
    truth: Truth
    rc: int
    k: float
    sigma: float
    parts: str
    warns: list[str]
    err: str
    c_tb: str = ""

    @property
    def z(self) -> float:
        return (self.k - self.truth.k_TB) / self.sigma if self.sigma > 0 else math.nan


def run(tmp: Path, name: str, family: str, t: Truth, calibrate_from: Truth | None = None) -> Row:
    rig = tmp / f"{name}.toml"
    if calibrate_from is not None:  # k_MS from `calibrate` on a steel-disk truth of the same rig
        disk_uff = tmp / f"{name}_disk.uff"
        write_uff(disk_uff, calibrate_from.freq, calibrate_from.frf(calibrate_from.freq))
        rig.write_text(t.rig_text(), encoding="utf-8")
        rc, res, err = cli("calibrate", str(disk_uff), "--rig", str(rig))
        if rc != 0 or res is None:
            return Row(family, t, rc, math.nan, math.nan, "", [f"calibrate: {err}"], err)
        k_ms, k_ms_std = float(res["k_MS"]), float(res["k_MS_std"])  # type: ignore[arg-type]
        rig.write_text(t.rig_text(k_MS=k_ms, k_MS_rel=k_ms_std / k_ms), encoding="utf-8")
        cal = [f"calibrate: k_MS {k_ms:.4g} +- {k_ms_std / k_ms:.2%} (true {calibrate_from.k_MS:.4g}); "
               + "; ".join(str(w) for w in res.get("warnings", []))]  # type: ignore[attr-defined]
    else:
        rig.write_text(t.rig_text(), encoding="utf-8")
        cal = []
    uff = tmp / f"{name}.uff"
    fr = t.freq
    write_uff(uff, fr, t.frf(fr), t.coherence(fr), t.n_avg if t.shaker_mass > 0 else 0)
    rc, res, err = cli("stiffness", str(uff), "--rig", str(rig))
    if rc != 0 or res is None:
        return Row(family, t, rc, math.nan, math.nan, "", cal, err)
    kinds = res.get("k_TB_std_by_kind") or {}
    parts = ", ".join(f"{key} {float(v) / float(res['k_TB']):.2%}"  # type: ignore[arg-type]
                      for key, v in kinds.items() if v)  # type: ignore[attr-defined]
    c_tb = ""
    if res.get("c_TB") is not None and t.c_TB > 0:
        c, cs = float(res["c_TB"]), float(res["c_TB_std"])  # type: ignore[arg-type]
        if res.get("c_TB_kind", "upper bound") == "measured":
            c_tb = f"{c:.4g} vs {t.c_TB:.4g} (z {(c - t.c_TB) / cs:+.2f}; measured, share {res.get('damping_share'):.2f})"
        else:  # an upper bound (its std the bound's own): holds when the truth is under c + 2 sigma
            c_tb = (f"<= {c:.4g} vs {t.c_TB:.4g} (bound {'holds' if t.c_TB <= c + 2 * cs else 'BROKEN'}, "
                    f"z {(c - t.c_TB) / cs:+.2f})")
    return Row(family, t, rc, float(res["k_TB"]), float(res["k_TB_std"]), parts,  # type: ignore[arg-type]
               cal + [str(w) for w in res.get("warnings", [])], err, c_tb)  # type: ignore[attr-defined]


def _r(s: int, salt: int) -> np.random.Generator:
    return np.random.default_rng(1000 * salt + s)


def _logk(s: int, salt: int, lo: float = 1e7, hi: float = 1e9) -> float:
    return float(10 ** _r(s, salt).uniform(math.log10(lo), math.log10(hi)))


def _grid(s: int) -> float:
    """k_TB of seed s on the log-spaced grid 1e7..1e9: its ends included at offset 0 (the old runs),
    shifted half a step (cell centres) at any other offset so that fresh seeds give fresh stiffnesses."""
    i, n = s - SEED_OFFSET[0], N_SEEDS[0]
    if SEED_OFFSET[0] == 0:
        return float(10 ** (7 + 2 * i / max(n - 1, 1)))
    return float(10 ** (7 + 2 * (i + 0.5) / n))


def families() -> dict[str, Callable[[int], tuple[Truth, Truth | None]]]:
    def frame(s: int) -> tuple[Truth, Truth | None]:
        r = _r(s, 3)
        sign = 1.0 if r.uniform() < 0.5 else -1.0
        return Truth(k_TB=_logk(s, 3, 3e7, 2e8), frame_ratio=1 + sign * float(r.uniform(0.01, 0.03)), seed=s), None

    def disk(s: int) -> tuple[Truth, Truth | None]:
        k_ms = TABLE1["k_MS"] * float(_r(s, 7).uniform(0.85, 1.15))
        return (Truth(k_TB=_logk(s, 7, 3e7, 2e8), k_MS=k_ms, seed=s),
                Truth(k_TB=math.inf, k_MS=k_ms, seed=s + 500))

    def mass_off(s: int, tol: float | None) -> tuple[Truth, Truth | None]:
        f = 1.2 if s % 2 else 0.8
        return Truth(k_TB=_logk(s, 5, 3e7, 2e8), m_H=TABLE1["m_H"] * f, file_tol={} if tol is None else {"m_H": tol},
                     seed=s), None

    def mass_near(s: int, lo: float, hi: float) -> tuple[Truth, Truth | None]:
        f = 1 + (1 if s % 2 else -1) * float(_r(s, 12).uniform(lo, hi))
        return Truth(k_TB=_logk(s, 12, 3e7, 2e8), m_H=TABLE1["m_H"] * f, seed=s), None

    def another_rig(s: int) -> tuple[Truth, Truth | None]:
        r = _r(s, 16)
        ms = float(2 ** r.uniform(-1, 1))
        ks = ms * float(r.uniform(0.85, 1.15)) ** 2
        fs = math.sqrt(ks / ms)  # the housing's lateral/axial and the spindle's axial modes move with the rig
        return Truth(k_TB=_logk(s, 16, 3e7, 2e8) * ks, k_MS=TABLE1["k_MS"] * ks, m_H=TABLE1["m_H"] * ms,
                     file_m_H=TABLE1["m_H"] * ms, mass_scale=ms, stiff_scale=ks, lat_freq=430.0 * fs,
                     ax_freq=310.0 * fs, sp_ax_freq=1012.0 * fs, seed=s), None

    def lateral_near(s: int) -> tuple[Truth, Truth | None]:
        r = _r(s, 18)
        t = Truth(k_TB=_logk(s, 18, 3e7, 2e8), seed=s)
        sign = 1.0 if r.uniform() < 0.5 else -1.0
        return Truth(k_TB=t.k_TB, lat_freq=t._housing_freq_3dof() * (1 + sign * float(r.uniform(0.01, 0.02))),
                     seed=s), None

    def _bw(t: Truth) -> float:
        """Half-power bandwidth [Hz] of the housing mode: 2 zeta f with the bearing's and the structure's zeta."""
        return 2 * (t.zeta_H + t.structure_zeta) * t._housing_freq_3dof()

    def coarse(s: int) -> tuple[Truth, Truth | None]:
        t = Truth(k_TB=_logk(s, 31, 3e7, 2e8), seed=s)
        return Truth(k_TB=t.k_TB, df=round(_bw(t) / float(_r(s, 31).uniform(3.0, 5.0)), 3), seed=s), None

    def band_edge(s: int, lo: float, hi: float, salt: int) -> tuple[Truth, Truth | None]:
        """The rig file's band ends lo-hi half-power bandwidths beyond the housing mode (above or below)."""
        t = Truth(k_TB=_logk(s, salt, 3e7, 2e8), seed=s)
        r = _r(s, salt)
        x = float(r.uniform(lo, hi)) * _bw(t)
        f = t._housing_freq_3dof()
        band = (150.0, f + x) if r.uniform() < 0.5 else (f - x, 1000.0)
        return Truth(k_TB=t.k_TB, band=band, seed=s), None

    def aniso(s: int) -> tuple[Truth, Truth | None]:
        r = _r(s, 33)
        d = (1 if r.uniform() < 0.5 else -1) * float(r.uniform(0.02, 0.06))
        return Truth(k_TB=_logk(s, 33, 3e7, 2e8), aniso_delta=d, aniso_deg=float(r.uniform(5.0, 25.0)), seed=s), None

    def spindle(s: int) -> tuple[Truth, Truth | None]:
        r = _r(s, 34)
        ratio = 1 + (1 if r.uniform() < 0.5 else -1) * float(r.uniform(0.01, 0.05))
        return Truth(k_TB=_logk(s, 34, 3e7, 2e8), spindle_ratio=ratio, spindle_mass=float(r.uniform(0.5, 2.0)),
                     seed=s), None

    def shaker(s: int) -> tuple[Truth, Truth | None]:
        r = _r(s, 35)
        return Truth(k_TB=_logk(s, 35, 3e7, 2e8), shaker_mass=float(r.uniform(0.1, 0.5)),
                     shaker_c=float(r.uniform(50.0, 300.0)), force_noise=float(r.uniform(0.02, 0.05)), seed=s), None

    def leak_n(s: int, lo: float, hi: float, salt: int) -> tuple[Truth, Truth | None]:
        """A Hann-windowed random test with lo-hi lines across the housing mode's half-power band."""
        t = Truth(k_TB=_logk(s, salt, 3e7, 2e8), seed=s)
        return Truth(k_TB=t.k_TB, df=round(_bw(t) / float(_r(s, salt).uniform(lo, hi)), 3), hann=True, seed=s), None

    def aniso_damped(s: int) -> tuple[Truth, Truth | None]:
        r = _r(s, 40)
        d = (1 if r.uniform() < 0.5 else -1) * float(r.uniform(0.02, 0.06))
        return Truth(k_TB=_logk(s, 40, 3e7, 2e8), aniso_delta=d, aniso_deg=float(r.uniform(5.0, 25.0)),
                     zeta_H=float(r.uniform(0.03, 0.08)), seed=s), None

    def shaker_damped(s: int) -> tuple[Truth, Truth | None]:
        r = _r(s, 41)
        return Truth(k_TB=_logk(s, 41, 3e7, 2e8), shaker_mass=float(r.uniform(0.2, 0.5)),
                     shaker_c=float(r.uniform(50.0, 300.0)), force_noise=float(r.uniform(0.02, 0.05)),
                     zeta_H=float(r.uniform(0.03, 0.08)), seed=s), None

    def spindle_far(s: int) -> tuple[Truth, Truth | None]:
        r = _r(s, 42)
        ratio = 1 + (1 if r.uniform() < 0.5 else -1) * float(r.uniform(0.05, 0.15))
        return Truth(k_TB=_logk(s, 42, 3e7, 2e8), spindle_ratio=ratio, spindle_mass=float(r.uniform(0.5, 2.0)),
                     seed=s), None

    new13 = {
        # r_truth13 (seeds 60+): physics none of the families above has
        "r13 anisotropic bearing: k_2/k_1 1 +- 2-6 %, principal axis 5-25 deg off the load direction": aniso,
        "r13 driving-point accelerometer 11+Y 5-15 deg off its axis (towards the lateral)": lambda s: (
            Truth(k_TB=_logk(s, 36, 3e7, 2e8), tilt=((0, ZH, float(_r(s, 36).uniform(5.0, 15.0))),), seed=s), None),
        "r13 radial accelerometer 12+Y 5-15 deg off its axis (towards the axial)": lambda s: (
            Truth(k_TB=_logk(s, 37, 3e7, 2e8), tilt=((1, XH, float(_r(s, 37).uniform(5.0, 15.0))),), seed=s), None),
        "r13 coarse resolution: 3-5 lines across the housing mode's half-power band": coarse,
        "r13 housing mode 1-3 half-power bandwidths inside the band's edge": lambda s: band_edge(s, 1.0, 3.0, 32),
        "r13 shaker force drop-out at resonance (armature 0.1-0.5 kg, back-EMF 50-300 N s/m), H1 of 30 averages "
        "with coherence": shaker,
        "r13 second shaker on 15+X in the file, the rig file names 11+Y only": lambda s: (
            Truth(k_TB=_logk(s, 38, 3e7, 2e8), second_ref=True, seed=s), None),
        "r13 spindle bending mode 1-5 % from the housing mode (0.5-2 kg)": spindle,
        "r13 Hann-windowed random test, 2-4 lines across the half-power band (leakage)": lambda s: leak_n(s, 2, 4, 43),
        "r13 radial housing sensor 12+Y written 12-Y in the rig file (sign reversed there only)": lambda s: (
            Truth(k_TB=_logk(s, 44, 3e7, 2e8), rig_flip=("12+Y",), seed=s), None),
        "r13 spindle sensor 21+Y written 21-Y in the rig file (sign reversed there only)": lambda s: (
            Truth(k_TB=_logk(s, 45, 3e7, 2e8), rig_flip=("21+Y",), seed=s), None),
        "r13 spindle sensor 21+Y reversed in the rig file, bearing zeta 3-8 %": lambda s: (
            Truth(k_TB=_logk(s, 46, 3e7, 2e8), rig_flip=("21+Y",), zeta_H=float(_r(s, 46).uniform(0.03, 0.08)),
                  seed=s), None),
        "r13 Hann-windowed random test, 3-5 lines across the half-power band (leakage)": lambda s: leak_n(s, 3, 5, 47),
        "r13 Hann-windowed random test, 5-10 lines across the half-power band (leakage)": lambda s: leak_n(s, 5, 10, 47),
        "r13 spindle bending mode 5-15 % from the housing mode (0.5-2 kg)": spindle_far,
        "r13 housing mode 0.3-1 half-power bandwidth inside the band's edge": lambda s: band_edge(s, 0.3, 1.0, 39),
        "r13 anisotropic bearing (as above) with bearing zeta 3-8 %": aniso_damped,
        "r13 shaker force drop-out (armature 0.2-0.5 kg) with bearing zeta 3-8 %": shaker_damped,
    }

    return new13 | {
        "k_TB 1e7..1e9 (log-uniform)": lambda s: (Truth(k_TB=_logk(s, 1), seed=s), None),
        "k_TB 1e7..1e9 (log-spaced grid over the seeds)": lambda s: (Truth(k_TB=_grid(s), seed=s), None),
        "frame part 1-3 % from the housing mode": frame,
        "sensor masses 10-60 g each, declared": lambda s: (
            Truth(k_TB=_logk(s, 4, 3e7, 2e8), sensor_mass=float(_r(s, 4).uniform(0.010, 0.060)), seed=s), None),
        "sensor masses 10-60 g each, NOT declared": lambda s: (
            Truth(k_TB=_logk(s, 6, 3e7, 2e8), sensor_mass=float(_r(s, 6).uniform(0.010, 0.060)),
                  declare_sensor_mass=False, seed=s), None),
        "m_H 20 % off the file (tol 0.5 %)": lambda s: mass_off(s, None),
        "m_H 20 % off the file (tol 20 % stated)": lambda s: mass_off(s, 0.20),
        "heavy bearing damping zeta 4-10 %": lambda s: (
            Truth(k_TB=_logk(s, 8, 3e7, 2e8), zeta_H=float(_r(s, 8).uniform(0.04, 0.10)), seed=s), None),
        "stiff bearing 3e8-1e9, zeta 4-10 %": lambda s: (
            Truth(k_TB=_logk(s, 9, 3e8, 1e9), zeta_H=float(_r(s, 9).uniform(0.04, 0.10)), seed=s), None),
        "bearing zeta 1-10 %, rig tolerances 1e-4": lambda s: (
            Truth(k_TB=_logk(s, 10, 3e7, 3e8), zeta_H=float(_r(s, 10).uniform(0.01, 0.10)), file_tol=TIGHT, seed=s),
            None),
        "k_MS from calibrate on a disk truth (k_MS 0.85-1.15 x)": disk,
        # r_review10: truths the e_mass9 / d_pair9 rules were not developed on
        "hysteretic bearing eta 2-20 %, no dashpot": lambda s: (
            Truth(k_TB=_logk(s, 13, 3e7, 3e8), zeta_H=0.0, bearing_loss=float(_r(s, 13).uniform(0.02, 0.20)),
                  seed=s), None),
        "hysteretic bearing eta 2-20 %, rig tolerances 1e-4": lambda s: (
            Truth(k_TB=_logk(s, 13, 3e7, 3e8), zeta_H=0.0, bearing_loss=float(_r(s, 13).uniform(0.02, 0.20)),
                  file_tol=TIGHT, seed=s), None),
        "damping in the housing's support zeta 1-6 %, bearing undamped": lambda s: (
            Truth(k_TB=_logk(s, 14, 3e7, 3e8), zeta_H=0.0, support_zeta=float(_r(s, 14).uniform(0.01, 0.06)),
                  seed=s), None),
        "spindle sensor masses 20-80 g each, NOT declared": lambda s: (
            Truth(k_TB=_logk(s, 15, 3e7, 2e8), spindle_sensor_mass=float(_r(s, 15).uniform(0.020, 0.080)), seed=s),
            None),
        "m_H 10-12 % off the file (tol 0.5 %)": lambda s: mass_near(s, 0.10, 0.12),
        "m_H 4-6 % off the file (tol 0.5 %)": lambda s: mass_near(s, 0.04, 0.06),
        # r_truth11: a test engineer's other rigs and other days
        "another rig: masses x0.5-2, stiffnesses to match (modes x0.85-1.15), rig file scaled": another_rig,
        "fewer averages: noise 3-6 % per line": lambda s: (
            Truth(k_TB=_logk(s, 17, 3e7, 3e8), noise=float(_r(s, 17).uniform(0.03, 0.06)), seed=s), None),
        "lateral mode 1-2 % from the housing mode": lateral_near,
        "structure damped 0.5-1 % (the spindle's support too), bearing zeta 3-8 %": lambda s: (
            Truth(k_TB=_logk(s, 20, 3e7, 2e8), zeta_H=float(_r(s, 20).uniform(0.03, 0.08)),
                  structure_zeta=float(_r(s, 20).uniform(0.005, 0.01)), seed=s), None),
        # r_truth12 (seeds 36+): rigs the rules were not developed on
        "second housing mode 1-4 % from the radial one, another shape (ovalisation-like), 5-20 kg": lambda s: (
            Truth(k_TB=_logk(s, 21, 3e7, 2e8),
                  second_ratio=1 + (1 if _r(s, 21).uniform() < 0.5 else -1) * float(_r(s, 22).uniform(0.01, 0.04)),
                  second_mass=float(_r(s, 23).uniform(5.0, 20.0)), seed=s), None),
        "spindle sensor masses 80-200 g each, NOT declared": lambda s: (
            Truth(k_TB=_logk(s, 24, 3e7, 2e8), spindle_sensor_mass=float(_r(s, 24).uniform(0.080, 0.200)), seed=s),
            None),
        "softer mounting k_MS 0.3-0.6 x Table 1 (the rig file states it)": lambda s: (
            Truth(k_TB=_logk(s, 25, 3e7, 2e8), k_MS=TABLE1["k_MS"] * float(_r(s, 25).uniform(0.3, 0.6)), seed=s),
            None),
        "very heavy bearing damping zeta 10-20 %": lambda s: (
            Truth(k_TB=_logk(s, 26, 3e7, 2e8), zeta_H=float(_r(s, 26).uniform(0.10, 0.20)), seed=s), None),
        "hysteretic bearing eta 20-40 %": lambda s: (
            Truth(k_TB=_logk(s, 27, 3e7, 2e8), zeta_H=0.0, bearing_loss=float(_r(s, 27).uniform(0.20, 0.40)),
                  seed=s), None),
        "bearing zeta 3-8 % with support damping zeta 1-3 %": lambda s: (
            Truth(k_TB=_logk(s, 19, 3e7, 2e8), zeta_H=float(_r(s, 19).uniform(0.03, 0.08)),
                  support_zeta=float(_r(s, 19).uniform(0.01, 0.03)), seed=s), None),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--seed-offset", type=int, default=0, help="first seed (0: the seeds the rules were tuned on)")
    ap.add_argument("--only", default="")
    ap.add_argument("-o", "--out", type=Path, default=None)
    ap.add_argument("--tree", type=Path, default=ROOT, help="ema_rig checkout the CLI runs from (before/after)")
    a = ap.parse_args(argv)
    TREE[0] = a.tree.resolve()
    N_SEEDS[0] = a.seeds
    SEED_OFFSET[0] = a.seed_offset
    lines = ["| family | seed | k_TB true | k_TB printed | err % | sigma % | z | exit | sigma parts (rel.) | c_TB printed vs true | warnings (else stderr's last line) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    summary = ["| family | n | ok (no warning, within 2 sigma) | warned, right (within 2 sigma) | warned, wrong |"
               " refused | SILENT (no warning, outside 2 sigma) | median sigma % | max |z| |",
               "|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmpd:
        tmp = Path(tmpd)
        for fam, make in families().items():
            if a.only and a.only not in fam:
                continue
            rows = []
            for s in range(a.seed_offset, a.seed_offset + a.seeds):
                t, disk = make(s)
                row = run(tmp, f"c{s}", fam, t, disk)
                rows.append(row)
                w = " / ".join(row.warns)[:400].replace("|", "/")
                line = (f"| {fam} | {s} | {t.k_TB:.4g} | {row.k:.4g} | {100 * (row.k / t.k_TB - 1):+.2f} | "
                        f"{100 * row.sigma / row.k:.2f} | {row.z:+.2f} | {row.rc} | {row.parts} | {row.c_tb} | "
                        f"{w or ('(stderr) ' + row.err if row.err else '')} |")
                lines.append(line)
                print(line, flush=True)
            ok = [r for r in rows if r.rc == 0 and not _warned(r) and abs(r.z) <= 2]
            wr = [r for r in rows if r.rc == 0 and _warned(r) and abs(r.z) <= 2]
            ww = [r for r in rows if r.rc == 0 and _warned(r) and not abs(r.z) <= 2]
            ref = [r for r in rows if r.rc != 0]
            sil = [r for r in rows if r.rc == 0 and not _warned(r) and not abs(r.z) <= 2]
            sig = [100 * r.sigma / r.k for r in rows if r.rc == 0]
            zs = [abs(r.z) for r in rows if r.rc == 0]
            summary.append(f"| {fam} | {len(rows)} | {len(ok)} | {len(wr)} | {len(ww)} | {len(ref)} | {len(sil)} | "
                           f"{np.median(sig) if sig else math.nan:.2f} | {max(zs) if zs else math.nan:.2f} |")
            print(summary[-1], flush=True)
    head = (f"ema_rig tree: {TREE[0]}; {a.seeds} seeds per family (seeds {a.seed_offset}..{a.seed_offset + a.seeds - 1});"
            " python -m ema_rig.cli at its defaults\n\n")
    text = head + "\n".join(summary) + "\n\n" + "\n".join(lines) + "\n"
    if a.out is not None:
        a.out.write_text(text, encoding="utf-8")
    return 0


def _warned(r: Row) -> bool:
    """A warning from the stiffness run itself (the calibrate line is context, not a warning)."""
    return any(not w.startswith("calibrate:") for w in r.warns)


if __name__ == "__main__":
    raise SystemExit(main())
