"""Setup half of bidex's GPU backend (sim/warp_backend.cc embeds this file).

Runs once, at construction: loads the scene that the C++ side compiled (a binary MuJoCo model),
puts it on the device with MuJoCo Warp, allocates the worlds and bidex's own per-world arrays,
and captures the control step and the reset passes as CUDA graphs. The C++ side then launches
those graphs and its own kernels on the same stream; no Python runs per step on a GPU.
On Warp's CPU device there are no graphs: the C++ side calls step() and the reset passes here.
"""

import dataclasses
import time

import mujoco
import mujoco_warp as mjw
import numpy as np
import warp as wp

wp.config.quiet = True  # no banner
wp.config.log_level = wp.LOG_WARNING  # no per-module load messages

# bits of a world's fault word (sim/batch.h FaultBits)
FAULT_BAD_INPUT = 1 << 0
FAULT_NONFINITE = 1 << 1
FAULT_EXPLODED = 1 << 2
FAULT_OVERFLOW = 1 << 5
# MuJoCo Warp's overflow bits that mean a world ran out of room (constraint rows, contacts,
# collision pairs, ...) and its step dropped data. Its solver's iteration caps (ITERATIONS,
# LS_ITERATIONS) are left out: such a step uses the last iterate, as MuJoCo's C library does on
# the CPU path without a warning, so neither path faults it.
ROOM_OVERFLOWS = int(mjw.OverflowType.ALL) & ~int(
  mjw.OverflowType.ITERATIONS | mjw.OverflowType.LS_ITERATIONS)
# bidex's kinds of room overflow (sim/warp_backend.h OverflowKind), each the setting that widens
# it: constraint rows (gpu.njmax), contacts and collision pairs (gpu.nconmax), the rest
OVERFLOW_ROWS = 1 << 0
OVERFLOW_CONTACTS = 1 << 1
OVERFLOW_OTHER = 1 << 2
ROWS_OVERFLOWS = int(mjw.OverflowType.NEFC | mjw.OverflowType.NJMAX_NNZ)
CONTACT_OVERFLOWS = int(mjw.OverflowType.BROADPHASE | mjw.OverflowType.NARROWPHASE)


@wp.kernel
def _base_wrench(
  root_body: wp.array(dtype=int),
  wrench: wp.array2d(dtype=float),
  xpos: wp.array2d(dtype=wp.vec3),
  xipos: wp.array2d(dtype=wp.vec3),
  xfrc_applied: wp.array2d(dtype=wp.spatial_vector),
):
  # a base force acts at the pivot (the body origin): MuJoCo applies xfrc at the centre of mass,
  # so the torque gets the force's moment about the pivot (sim/batch.cc update_base_wrench)
  w, h = wp.tid()
  b = root_body[h]
  if b < 0:  # a fixed base
    return
  f = wp.vec3(wrench[w, 6 * h + 0], wrench[w, 6 * h + 1], wrench[w, 6 * h + 2])
  t = wp.vec3(wrench[w, 6 * h + 3], wrench[w, 6 * h + 4], wrench[w, 6 * h + 5])
  r = xpos[w, b] - xipos[w, b]
  t = t + wp.cross(r, f)
  xfrc_applied[w, b] = wp.spatial_vector(f[0], f[1], f[2], t[0], t[1], t[2])


@wp.kernel
def _check(
  ctrl: wp.array2d(dtype=float),
  wrench: wp.array2d(dtype=float),
  qpos: wp.array2d(dtype=float),
  qvel: wp.array2d(dtype=float),
  max_speed: float,
  overflow: wp.array(dtype=int),
  nefc: wp.array(dtype=int),
  fault: wp.array(dtype=wp.uint32),
  fault_count: wp.array(dtype=wp.int64),
  fault_seen: wp.array(dtype=wp.uint32),
  overflow_count: wp.array(dtype=wp.int64),
  overflow_seen: wp.array(dtype=wp.uint32),
  rows_max: wp.array(dtype=wp.int32),
  solver_niter: wp.array(dtype=int),
  efc_rows: wp.array(dtype=wp.int64),
  solver_iters: wp.array(dtype=wp.int64),
  reset: wp.array(dtype=wp.int32),
):
  w = wp.tid()
  bits = wp.uint32(0)
  # the most constraint rows this world has needed (its room's use; an overflow counts above)
  rows_max[w] = wp.max(rows_max[w], wp.int32(nefc[w]))
  # the physics' load, summed over control steps as sim/batch.cc sums it on the CPU
  efc_rows[w] = efc_rows[w] + wp.int64(nefc[w])
  solver_iters[w] = solver_iters[w] + wp.int64(solver_niter[w])
  # inputs: MuJoCo Warp clamps a NaN target into the control range, so check them here
  for i in range(ctrl.shape[1]):
    if not wp.isfinite(ctrl[w, i]):
      bits = bits | wp.uint32(FAULT_BAD_INPUT)
  for i in range(wrench.shape[1]):
    if not wp.isfinite(wrench[w, i]):
      bits = bits | wp.uint32(FAULT_BAD_INPUT)
  for i in range(qpos.shape[1]):
    if not wp.isfinite(qpos[w, i]):
      bits = bits | wp.uint32(FAULT_NONFINITE)
  for i in range(qvel.shape[1]):
    v = qvel[w, i]
    if not wp.isfinite(v):
      bits = bits | wp.uint32(FAULT_NONFINITE)
    elif wp.abs(v) > max_speed:
      bits = bits | wp.uint32(FAULT_EXPLODED)
  room = overflow[w] & ROOM_OVERFLOWS
  if room != 0:
    bits = bits | wp.uint32(FAULT_OVERFLOW)
    overflow_count[w] = overflow_count[w] + wp.int64(1)
    kinds = wp.uint32(0)
    if (room & ROWS_OVERFLOWS) != 0:
      kinds = kinds | wp.uint32(OVERFLOW_ROWS)
    if (room & CONTACT_OVERFLOWS) != 0:
      kinds = kinds | wp.uint32(OVERFLOW_CONTACTS)
    if (room & ~(ROWS_OVERFLOWS | CONTACT_OVERFLOWS)) != 0:
      kinds = kinds | wp.uint32(OVERFLOW_OTHER)
    overflow_seen[w] = overflow_seen[w] | kinds
  overflow[w] = 0
  fault[w] = bits
  if bits != wp.uint32(0):
    fault_count[w] = fault_count[w] + wp.int64(1)
    fault_seen[w] = fault_seen[w] | bits
    reset[w] = 1
  else:
    reset[w] = 0


@wp.kernel
def _reset_inputs(
  reset: wp.array(dtype=wp.int32),
  act_qposadr: wp.array(dtype=int),
  ctrl_lo: wp.array(dtype=float),
  ctrl_hi: wp.array(dtype=float),
  qpos: wp.array2d(dtype=float),
  ctrl: wp.array2d(dtype=float),
  wrench: wp.array2d(dtype=float),
  xfrc_applied: wp.array2d(dtype=wp.spatial_vector),
  qfrc_actuator: wp.array2d(dtype=float),
  qfrc_constraint: wp.array2d(dtype=float),
):
  # a reset world: position targets at the current joints (inside the control range), no base
  # forces (sim/batch.cc reset_slot), and no joint forces until its first step: MuJoCo Warp's
  # reset_data keeps the last step's, which the first observation would read (mj_resetData on
  # the CPU clears them)
  w = wp.tid()
  if reset[w] == 0:
    return
  for i in range(qfrc_actuator.shape[1]):
    qfrc_actuator[w, i] = 0.0
    qfrc_constraint[w, i] = 0.0
  for a in range(ctrl.shape[1]):
    target = float(0.0)
    if act_qposadr[a] >= 0:
      target = qpos[w, act_qposadr[a]]
    ctrl[w, a] = wp.clamp(target, ctrl_lo[a], ctrl_hi[a])
  for k in range(wrench.shape[1]):
    wrench[w, k] = 0.0
  for b in range(xfrc_applied.shape[1]):
    xfrc_applied[w, b] = wp.spatial_vector()


@wp.kernel
def _random_inputs(
  seed: int,
  step: int,
  ctrl_lo: wp.array(dtype=float),
  ctrl_hi: wp.array(dtype=float),
  max_force: float,
  max_torque: float,
  ctrl: wp.array2d(dtype=float),
  wrench: wp.array2d(dtype=float),
):
  # benchmarks: uniform targets over the control ranges, base forces and torques up to the caps
  w = wp.tid()
  state = wp.rand_init(seed, w * 7919 + step)
  for a in range(ctrl.shape[1]):
    ctrl[w, a] = ctrl_lo[a] + (ctrl_hi[a] - ctrl_lo[a]) * wp.randf(state)
  for k in range(wrench.shape[1]):
    cap = max_force
    if (k % 6) >= 3:
      cap = max_torque
    wrench[w, k] = cap * (2.0 * wp.randf(state) - 1.0)


@wp.kernel
def _random_fill(seed: int, step: int, lo: float, hi: float, out: wp.array2d(dtype=float)):
  # benchmarks: uniform values in [lo, hi) per world (random actions)
  w = wp.tid()
  state = wp.rand_init(seed, w * 7919 + step + 1000003)
  for k in range(out.shape[1]):
    out[w, k] = lo + (hi - lo) * wp.randf(state)


def _batched(model_type, name):
  """Whether a field of a MuJoCo Warp dataclass takes per-world values (leading size "*")."""
  for f in dataclasses.fields(model_type):
    if f.name == name:
      shape = getattr(f.type, "shape", ())
      return bool(shape) and shape[0] == "*"
  return False


def _values(x):
  """A field's value in a comparable form: arrays as numpy, sequences and dataclasses by part."""
  if isinstance(x, wp.array):
    return ("array", x.numpy())
  if dataclasses.is_dataclass(x):
    return ("struct", {f.name: _values(getattr(x, f.name)) for f in dataclasses.fields(x)})
  if isinstance(x, (tuple, list)):
    return ("seq", [_values(v) for v in x])
  return ("value", x)


def _equal(a, b):
  if a[0] != b[0]:
    return False
  if a[0] == "array":
    return a[1].shape == b[1].shape and a[1].dtype == b[1].dtype and np.array_equal(a[1], b[1])
  if a[0] == "struct":
    return a[1].keys() == b[1].keys() and all(_equal(a[1][k], b[1][k]) for k in a[1])
  if a[0] == "seq":
    return len(a[1]) == len(b[1]) and all(_equal(x, y) for x, y in zip(a[1], b[1]))
  return type(a[1]) is type(b[1]) and a[1] == b[1]


def _fields(model):
  """A Model's fields as {(owner, name): (batched, value)}: owner is "" for the Model's own
  fields, else the nested dataclass (its options) that holds the field."""
  out = {}
  for f in dataclasses.fields(model):
    x = getattr(model, f.name)
    if dataclasses.is_dataclass(x) and not isinstance(x, wp.array):
      for g in dataclasses.fields(x):
        out[(f.name, g.name)] = (_batched(type(x), g.name), _values(getattr(x, g.name)))
    else:
      out[("", f.name)] = (_batched(type(model), f.name), _values(x))
  return out


def _differences(base, other):
  """The fields in which two scenes' models (as _fields gives them) differ: (owner, name,
  batched)."""
  return [(owner, name, batched) for (owner, name), (batched, value) in base.items()
          if not _equal(value, other[(owner, name)][1])]


def _put_models(mjms):
  models = []
  for mjm in mjms:
    m = mjw.put_model(mjm)
    # set on every scene alike (Bridge.__init__), so the comparison sees the stepped options
    m.opt.warn_overflow = 0
    m.opt.disableflags = m.opt.disableflags | int(mjw.DisableBit.NATIVECCD)
    models.append(m)
  return models


def topology_groups(mjb_paths):
  """Groups scenes that one MuJoCo Warp Model can step: scenes whose models differ only in
  fields it takes per world (body and joint poses, axes, initial positions, ...). Returns each
  scene's group, numbered by first appearance."""
  with wp.ScopedDevice("cpu"):
    models = [_fields(m) for m in _put_models([mujoco.MjModel.from_binary_path(p)
                                                for p in mjb_paths])]
  heads, out = [], []
  for m in models:
    for g, h in enumerate(heads):
      if all(batched for _, _, batched in _differences(models[h], m)):
        out.append(g)
        break
    else:
      out.append(len(heads))
      heads.append(len(out) - 1)
  return out


def _per_world(models, worlds):
  """One Model for worlds of several scenes: the first scene's, with every field in which the
  others differ replaced by per-world values (world w reads its own scene's). Raises ValueError
  naming a field MuJoCo Warp cannot take per world."""
  base = models[0]
  if len(models) == 1:
    return base
  values = [_fields(m) for m in models]
  fields = {}
  for k in range(1, len(models)):
    for owner, name, batched in _differences(values[0], values[k]):
      if not batched:
        raise ValueError(f"scenes 0 and {k} differ in MuJoCo Warp's field "
                         f"{owner + '.' if owner else ''}{name}, which it cannot take per world")
      fields[(owner, name)] = True
  if ("", "actuator_ctrlrange") in fields:  # bidex's reset pass reads the first scene's
    raise ValueError("the scenes differ in their actuators' control ranges")
  for owner, name in fields:
    parts = []
    for m, n in zip(models, worlds):
      a = getattr(getattr(m, owner) if owner else m, name)
      parts.append(np.repeat(a.numpy()[:1], n, axis=0))
    target = getattr(base, owner) if owner else base
    setattr(target, name, wp.array(np.concatenate(parts), dtype=getattr(target, name).dtype))
  return base


class Bridge:
  """The worlds of one scene, or of several scenes of one topology (topology_groups), on one
  Warp device."""

  def __init__(self, mjb_paths, worlds, substeps, njmax, nconmax, max_speed, root_bodies, device,
               sensors_every_substep=False):
    """mjb_paths and worlds: per scene, its compiled model and its worlds, which follow the
    previous scene's. root_bodies: per hand, the base body a base wrench acts on (-1: a fixed
    base)."""
    wp.init()
    if device.startswith("cuda") and not wp.is_cuda_available():
      raise RuntimeError("no CUDA device: Warp found no GPU or no working NVIDIA driver")
    self.device = wp.get_device(device)
    # a stream of its own: the scenes of a pack step concurrently (taskpack/warp_pack.h)
    self._stream = wp.Stream(self.device) if self.device.is_cuda else None
    mjms = [mujoco.MjModel.from_binary_path(p) for p in mjb_paths]
    self.mjm = mjms[0]
    self.worlds = [int(n) for n in worlds]
    nworld = sum(self.worlds)
    self.nworld = nworld
    self.substeps = substeps
    self.max_speed = max_speed
    mjm = self.mjm
    with wp.ScopedDevice(self.device):
      mjd = mujoco.MjData(mjm)
      # overflows are counted per world (_check), not printed; box-box pairs take MuJoCo's own
      # box-box collider (MuJoCo Warp's port of it, on its primitive path, up to 8 contacts), as
      # the CPU path's MuJoCo does, instead of MuJoCo Warp's default GJK/EPA (up to 4): the
      # NATIVECCD flag changes nothing else in MuJoCo Warp (_put_models)
      self.m = _per_world(_put_models(mjms), self.worlds)
      self.d = mjw.put_data(mjm, mjd, nworld=nworld, njmax=njmax, nconmax=nconmax)
      if len(mjms) > 1:  # each world from its own scene's initial state
        mjw.reset_data(self.m, self.d)
      nwrench = 6 * len(root_bodies)
      self.root_body = wp.array(np.asarray(root_bodies, dtype=np.int32), dtype=int)
      self.has_free_base = any(b >= 0 for b in root_bodies)
      self.base_wrench = wp.zeros((nworld, max(nwrench, 1)), dtype=float)
      self.fault = wp.zeros(nworld, dtype=wp.uint32)
      self.fault_count = wp.zeros(nworld, dtype=wp.int64)
      self.fault_seen = wp.zeros(nworld, dtype=wp.uint32)  # every kind a world has met
      self.overflow_count = wp.zeros(nworld, dtype=wp.int64)
      self.overflow_seen = wp.zeros(nworld, dtype=wp.uint32)  # every OVERFLOW_* kind met
      self.rows_max = wp.zeros(nworld, dtype=wp.int32)
      self.efc_rows = wp.zeros(nworld, dtype=wp.int64)
      self.solver_iters = wp.zeros(nworld, dtype=wp.int64)
      self.reset_mask = wp.zeros(nworld, dtype=wp.int32)
      qposadr = np.full(mjm.nu, -1, dtype=np.int32)
      for a in range(mjm.nu):
        if mjm.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT:
          qposadr[a] = mjm.jnt_qposadr[mjm.actuator_trnid[a, 0]]
      limited = mjm.actuator_ctrllimited.astype(bool)
      lo = np.where(limited, mjm.actuator_ctrlrange[:, 0], -np.inf).astype(np.float32)
      hi = np.where(limited, mjm.actuator_ctrlrange[:, 1], np.inf).astype(np.float32)
      self.act_qposadr = wp.array(qposadr, dtype=int)
      self.ctrl_lo = wp.array(lo, dtype=float)
      self.ctrl_hi = wp.array(hi, dtype=float)
      # every world starts reset: targets at the joints, no base forces
      self.reset_mask.fill_(1)
      self._reset_inputs()
      mjw.forward(self.m, self.d)
      self.reset_mask.zero_()
      wp.synchronize_device(self.device)
    # The tasks read sensors once per control step, after its last substep, and MuJoCo's
    # sensors are instantaneous unless one keeps a history (delay, interval). Without one, the
    # substeps before the last skip the sensor stages (for force and torque sensors that
    # includes a whole post-constraint RNE pass): the last substep computes the same values.
    self.sensors_last_only = bool(
      not sensors_every_substep and mjm.nsensor > 0 and not np.any(mjm.sensor_history)
      and not np.any(mjm.sensor_delay) and not np.any(mjm.sensor_interval))
    self.graphs = {}
    self.extra = {}

  # ---- the passes (captured as graphs on a GPU) ----

  def step(self):
    """One control step: substeps of physics with the base forces at the pivots, then the
    fault check, which marks faulty worlds in reset_mask."""
    m, d = self.m, self.d
    for k in range(self.substeps):
      if self.has_free_base:
        wp.launch(_base_wrench, dim=(self.nworld, self.root_body.shape[0]),
                  inputs=[self.root_body, self.base_wrench, d.xpos, d.xipos, d.xfrc_applied])
      if k < self.substeps - 1 and self.sensors_last_only:
        self._step_without_sensors()
      else:
        mjw.step(m, d)
    wp.launch(_check, dim=self.nworld,
              inputs=[d.ctrl, self.base_wrench, d.qpos, d.qvel, self.max_speed, d.overflow,
                      d.nefc, self.fault, self.fault_count, self.fault_seen, self.overflow_count,
                      self.overflow_seen, self.rows_max, d.solver_niter, self.efc_rows,
                      self.solver_iters, self.reset_mask])

  def _step_without_sensors(self):
    # the option is read when kernels are launched (or captured), so it holds for this call only
    flags = self.m.opt.disableflags
    self.m.opt.disableflags = flags | int(mjw.DisableBit.SENSOR)
    try:
      mjw.step(self.m, self.d)
    finally:
      self.m.opt.disableflags = flags

  def raw_step(self):
    """The same substeps without bidex's passes (benchmarks compare the two)."""
    for _ in range(self.substeps):
      mjw.step(self.m, self.d)

  def reset_begin(self):
    """Marked worlds back to the model's initial state, targets at the joints, no forces."""
    mjw.reset_data(self.m, self.d, reset=self.reset_mask)
    self._reset_inputs()

  def reset_end(self):
    """The position pass after reset rows were written: poses, centres of mass, velocities."""
    mjw.kinematics(self.m, self.d)
    mjw.com_pos(self.m, self.d)
    mjw.com_vel(self.m, self.d)

  def random_inputs(self, seed, step, max_force, max_torque):
    wp.launch(_random_inputs, dim=self.nworld,
              inputs=[seed, step, self.ctrl_lo, self.ctrl_hi, max_force, max_torque, self.d.ctrl,
                      self.base_wrench], device=self.device, stream=self._stream)

  def random_fill(self, name, width, seed, step, lo, hi):
    a = self.extra[name]
    rows = a.shape[0]  # a pack's rows span all its scenes' worlds
    view = wp.array(ptr=a.ptr, dtype=float, shape=(rows, width), device=self.device)
    wp.launch(_random_fill, dim=rows, inputs=[seed, step, lo, hi, view],
              device=self.device, stream=self._stream)

  def _reset_inputs(self):
    wp.launch(_reset_inputs, dim=self.nworld,
              inputs=[self.reset_mask, self.act_qposadr, self.ctrl_lo, self.ctrl_hi, self.d.qpos,
                      self.d.ctrl, self.base_wrench, self.d.xfrc_applied, self.d.qfrc_actuator,
                      self.d.qfrc_constraint])

  # ---- graphs ----

  def capture(self, name):
    """Captures one pass as a CUDA graph; returns its executable graph handle."""
    fn = getattr(self, name)
    with wp.ScopedDevice(self.device), wp.ScopedStream(self._stream):
      fn()  # loads the kernels' modules before the capture
      with wp.ScopedCapture() as cap:
        fn()
      graph = cap.graph
      if graph.graph_exec is None:  # Warp instantiates a graph at its first launch
        wp.capture_launch(graph)
      wp.synchronize_stream(self._stream)
    self.graphs[name] = graph
    g = graph.graph_exec
    return int(g.value if hasattr(g, "value") else g)

  def run(self, name):
    """Runs one pass: its graph on a GPU, the Python pass on Warp's CPU device."""
    g = self.graphs.get(name)
    if g is not None:
      wp.capture_launch(g, stream=self._stream)
    else:
      with wp.ScopedDevice(self.device):
        getattr(self, name)()

  def synchronize(self):
    wp.synchronize_device(self.device)

  _PHASE_BATCHES = 3

  def phase_profile(self, steps):
    """Time of raw stepping's parts, in milliseconds per call, each part replayed (as a graph on
    a GPU) on the state that `steps` control steps of the current inputs reach:
      collision: collision detection (mjw.collision), a function of the positions alone;
      make_constraint: the constraint rows (mjw.make_constraint);
      forward_before_solve: forward dynamics up to the constraint solver;
      forward: forward dynamics (mjw.forward). Replayed on one state, its solver starts from the
        same warm start each time, as the next step's would, so forward less
        forward_before_solve is the solver's time (with what forward does after it);
      step: a whole substep (mjw.step), replayed as stepping goes on.
    Sensors are off in every part (the tasks read them once a control step). Each part's time is
    the fastest of three batches of `steps` control steps' substeps."""
    m, d = self.m, self.d

    def before_solve():
      mjw.fwd_position(m, d, factorize=False)
      mjw.fwd_velocity(m, d)
      mjw.fwd_actuation(m, d)
      mjw.fwd_acceleration(m, d, factorize=True)

    parts = [("collision", lambda: mjw.collision(m, d)),
             ("make_constraint", lambda: mjw.make_constraint(m, d)),
             ("forward_before_solve", before_solve),
             ("forward", lambda: mjw.forward(m, d)),
             ("step", lambda: mjw.step(m, d))]
    steps = max(int(steps), 1)
    reps = steps * self.substeps
    out = {}
    with wp.ScopedDevice(self.device), wp.ScopedStream(self._stream):
      for _ in range(steps):
        self.raw_step()
      flags = m.opt.disableflags
      m.opt.disableflags = flags | int(mjw.DisableBit.SENSOR)
      try:
        for name, fn in parts:
          fn()  # the kernels' modules loaded, outside the timing
          graph = None
          if self.device.is_cuda:
            with wp.ScopedCapture() as cap:
              fn()
            graph = cap.graph
          # the fastest of a few batches: forward less forward_before_solve is a difference of
          # two timings, which another process's load on a busy machine could otherwise turn
          # negative
          best = float("inf")
          for _ in range(self._PHASE_BATCHES):
            wp.synchronize_device(self.device)
            t0 = time.perf_counter()
            for _ in range(reps):
              if graph is not None:
                wp.capture_launch(graph, stream=self._stream)
              else:
                fn()
            wp.synchronize_device(self.device)
            best = min(best, time.perf_counter() - t0)
          out[name] = 1e3 * best / reps
      finally:
        m.opt.disableflags = flags
    return out

  # ---- what the C++ side reads ----

  def alloc(self, name, width_bytes, rows):
    """A zeroed (rows, width_bytes) byte array on the device for the C++ side (task state and
    outputs); returns its address."""
    with wp.ScopedDevice(self.device):
      a = wp.zeros((rows, max(width_bytes, 1)), dtype=wp.uint8)
      wp.synchronize_device(self.device)  # zeroed before the C++ side's stream uses it
    self.extra[name] = a
    return int(a.ptr)

  def arrays(self):
    """Per named array: (address, rows, values per row, bytes per row)."""
    d = self.d
    named = {
      "qpos": d.qpos, "qvel": d.qvel, "ctrl": d.ctrl, "qfrc_actuator": d.qfrc_actuator,
      "qfrc_constraint": d.qfrc_constraint, "sensordata": d.sensordata, "xpos": d.xpos,
      "xquat": d.xquat, "cvel": d.cvel, "subtree_com": d.subtree_com, "mocap_pos": d.mocap_pos,
      "mocap_quat": d.mocap_quat, "xfrc_applied": d.xfrc_applied, "time": d.time,
      "base_wrench": self.base_wrench, "fault": self.fault, "fault_count": self.fault_count,
      "fault_seen": self.fault_seen,
      "overflow_count": self.overflow_count, "overflow_seen": self.overflow_seen,
      "rows_max": self.rows_max, "efc_rows": self.efc_rows,
      "solver_iters": self.solver_iters, "reset": self.reset_mask,
    }
    out = {}
    for k, a in named.items():
      width = int(np.prod(a.shape[1:])) * (a.dtype._length_ if hasattr(a.dtype, "_length_") else 1)
      out[k] = (int(a.ptr) if a.ptr else 0, int(a.shape[0]), width, int(a.strides[0]))
    return out

  def stream(self):
    """(CUDA context, stream) handles, 0 on the CPU device."""
    if not self.device.is_cuda:
      return (0, 0)
    return (int(self.device.context), int(self._stream.cuda_stream))

  def memory(self):
    """Bytes Warp holds on the device (model, data and bidex's arrays)."""
    if not self.device.is_cuda:
      return 0
    return int(wp.get_mempool_used_mem_current(self.device))
