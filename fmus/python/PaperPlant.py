"""The paper's Section 6 plant as a PythonFMU co-simulation slave (one step = one sample):
x_t = -a1 x_{t-1} - a2 x_{t-2} + b0 u_t + b1 u_{t-1} + b2 u_{t-2}, then the output backlash of
eq (2), with the operations in the order of fmus/common/paper_core.h (bit-identical results).
Build: `pythonfmu build -f fmus/python/PaperPlant.py -d <dir>` (tests/fmu_python.rs does)."""
from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Real


class PaperPlant(Fmi2Slave):
    author = "smid"
    description = "Linear second-order block followed by an output backlash (paper Section 6)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.u, self.w, self.x = 0.0, 0.0, 0.0
        self.a1, self.a2, self.b0, self.b1, self.b2 = 0.5, 0.7, 0.0, 1.4, 0.8
        self.m_l, self.c_l, self.m_r, self.c_r = 0.248, 0.0698, 0.252, 0.0349
        self.s = [0.0] * 5  # x_{t-1}, x_{t-2}, u_{t-1}, u_{t-2}, w_{t-1}
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        for name in ("w", "x"):  # exact start values (0 at rest): no InitialUnknowns entry
            self.register_variable(
                Real(name, causality=Fmi2Causality.output, initial=Fmi2Initial.exact))
        for name in ("a1", "a2", "b0", "b1", "b2", "m_l", "c_l", "m_r", "c_r"):
            self.register_variable(
                Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))

    def do_step(self, current_time, step_size):
        x1, x2, u1, u2, w1 = self.s
        v = 0.0
        v += self.b0 * self.u
        v += self.b1 * u1
        v += self.b2 * u2
        v -= self.a1 * x1
        v -= self.a2 * x2
        if v <= w1 / self.m_l - self.c_l:
            w = self.m_l * (v + self.c_l)
        elif v >= w1 / self.m_r + self.c_r:
            w = self.m_r * (v - self.c_r)
        else:
            w = w1
        self.s = [v, x1, self.u, u1, w]
        self.x, self.w = v, w
        return True
