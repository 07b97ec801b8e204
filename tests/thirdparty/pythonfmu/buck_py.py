"""BuckPy: the averaged buck converter as a pythonfmu Co-Simulation FMU, a blind target for
`buckid identify`.

Built by `tests/thirdparty/build.sh` with `pythonfmu build` into `target/thirdparty/BuckPy.fmu`.
The load capacitance `CL` below is deliberately NOT an FMU variable: the identification has to
find it from the terminal behaviour alone. Names differ from our FMU on purpose (inputs `D`,
`Iload`, `Vin`; outputs `Vout`, `IL`) so that the CLI's `--map ROLE=NAME` is exercised.

Physics (design.md §1, averaged, u_sw = D·Vin), states x = (il, vc, vo):

    L  dil/dt = u_sw - RL·il - vo
    C  dvc/dt = (vo - vc)/Rc
    Cl dvo/dt = il - io - (vo - vc)/Rc

The model is linear, so each `do_step` of length h is integrated EXACTLY for inputs held
constant over the step (zero-order hold): x(t+h) = Φ(h)·x(t) + Γ(h)·(u_sw, io), with
[[Φ, Γ], [0, I]] = expm(h·[[A, B], [0, 0]]) computed here in pure Python (scaling and squaring
of a Taylor series; numpy inside a pythonfmu FMU crashes the host at exit) and cached per h, so
any communication step size works. The state starts at the averaged DC point of the inputs
present at the end of initialization: il = Iload, vc = vo = D·Vin - RL·Iload.

pythonfmu quirks: the binary finds the class with the regex `^class (\\w+)\\(\\s*Fmi2Slave\\s*\\)\\s*:`,
so the class line below must keep exactly that form; `fmi2Reset` re-creates the Python object
(so `__init__` must leave it in its start state); pythonfmu writes no
ModelStructure/InitialUnknowns, so outputs with the default initial="calculated" fail
`fmpy validate`: they are declared initial="exact" (their start is the DC point of the start
inputs).
"""

import math

from pythonfmu import DefaultExperiment, Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Initial, Fmi2Status

# Circuit (thesis values) and the hidden load capacitance.
L = 3.3e-6
RL = 0.1
C = 100e-6
RC = 0.1
FS = 330e3
CL = 4.7e-6  # hidden: the blind target of the identification

# Continuous-time A (3x3) and B (3x2, inputs u_sw and io).
_A = [
    [-RL / L, 0.0, -1.0 / L],
    [0.0, -1.0 / (RC * C), 1.0 / (RC * C)],
    [1.0 / CL, 1.0 / (RC * CL), -1.0 / (RC * CL)],
]
_B = [
    [1.0 / L, 0.0],
    [0.0, 0.0],
    [0.0, -1.0 / CL],
]


def _matmul(a, b):
    n, m, p = len(a), len(b), len(b[0])
    return [[math.fsum(a[i][k] * b[k][j] for k in range(m)) for j in range(p)] for i in range(n)]


def _expm(m):
    """exp(m) of a small square matrix (list of lists): scaling and squaring of a Taylor series.

    The scaled matrix has 1-norm <= 1/4, so 20 Taylor terms leave a truncation error far below
    double rounding; the squarings then cost only rounding (the system is stable, so the powers
    stay bounded).
    """
    n = len(m)
    norm = max(sum(abs(m[i][j]) for i in range(n)) for j in range(n))
    s = 0
    if norm > 0.25:
        s = max(0, math.ceil(math.log2(norm / 0.25)))
    scale = 2.0 ** -s
    x = [[v * scale for v in row] for row in m]
    result = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    term = [row[:] for row in result]
    for k in range(1, 21):
        term = _matmul(term, x)
        term = [[v / k for v in row] for row in term]
        result = [[result[i][j] + term[i][j] for j in range(n)] for i in range(n)]
    for _ in range(s):
        result = _matmul(result, result)
    return result


_CACHE = {}


def zoh(h):
    """(Φ, Γ) of the exact zero-order-hold step of length h, cached per h."""
    hit = _CACHE.get(h)
    if hit is not None:
        return hit
    aug = [[0.0] * 5 for _ in range(5)]
    for i in range(3):
        for j in range(3):
            aug[i][j] = _A[i][j] * h
        for j in range(2):
            aug[i][3 + j] = _B[i][j] * h
    e = _expm(aug)
    phi = [e[i][0:3] for i in range(3)]
    gamma = [e[i][3:5] for i in range(3)]
    if len(_CACHE) > 256:  # a host that varies its step a lot: keep memory bounded
        _CACHE.clear()
    _CACHE[h] = (phi, gamma)
    return phi, gamma


class BuckPy(Fmi2Slave):

    author = "buckid tests"
    description = "Averaged buck converter (exact ZOH steps) with a hidden load capacitance"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=1e-3, step_size=1.0 / FS)
        # Inputs
        self.D = 0.5
        self.Iload = 1.0
        self.Vin = 12.0
        # State (il, vc, vo) and outputs, at the DC point of the start inputs.
        self._x = self._dc_point()
        self.Vout = self._x[2]
        self.IL = self._x[0]
        self.register_variable(Real("D", causality=Fmi2Causality.input,
                                    description="duty cycle (0..1)"))
        self.register_variable(Real("Iload", causality=Fmi2Causality.input,
                                    description="load current [A]"))
        self.register_variable(Real("Vin", causality=Fmi2Causality.input,
                                    description="input voltage [V]"))
        self.register_variable(Real("Vout", causality=Fmi2Causality.output, initial=Fmi2Initial.exact,
                                    variability=Fmi2Variability.continuous,
                                    description="output voltage across the load capacitor [V]"))
        self.register_variable(Real("IL", causality=Fmi2Causality.output, initial=Fmi2Initial.exact,
                                    variability=Fmi2Variability.continuous,
                                    description="inductor current [A]"))

    def _dc_point(self):
        vo = self.D * self.Vin - RL * self.Iload
        return [self.Iload, vo, vo]

    def _inputs_ok(self):
        ok = all(math.isfinite(v) for v in (self.D, self.Iload, self.Vin)) and 0.0 <= self.D <= 1.0
        if not ok:
            self.log(f"invalid inputs D={self.D}, Iload={self.Iload}, Vin={self.Vin} "
                     "(D must be in 0..1, all finite)", Fmi2Status.error)
        return ok

    def exit_initialization_mode(self):
        self._x = self._dc_point()
        self.Vout = self._x[2]
        self.IL = self._x[0]

    def do_step(self, current_time, step_size):
        if not self._inputs_ok():
            return False
        if not step_size > 0.0:
            return True
        phi, gamma = zoh(step_size)
        u = (self.D * self.Vin, self.Iload)
        x = self._x
        self._x = [
            phi[i][0] * x[0] + phi[i][1] * x[1] + phi[i][2] * x[2]
            + gamma[i][0] * u[0] + gamma[i][1] * u[1]
            for i in range(3)
        ]
        self.Vout = self._x[2]
        self.IL = self._x[0]
        return True
