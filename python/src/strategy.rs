//! Strategies written in Python: `register_strategy(name, factory)` makes `factory(params)`
//! the maker of a strategy configs can name; each robot of a group gets its own object, whose
//! `decide(robot)` returns an action every round.
//!
//! `robot` is a [`Robot`]: a copy of what the Rust `Ctx` offers (position, energy, load, the
//! robot's type, treasures and robots in view, messages), and methods that act through the
//! context while `decide` runs (the known map, the seeded random generator, messages to
//! send). Those methods reach the context through scoped thread-locals set around the call
//! (`scoped-tls`), so a `Robot` kept beyond its `decide` refuses them instead of reading
//! another round's state.
//!
//! An exception in `decide` disables that robot alone: the traceback is the reason in the
//! event log ([`StrategyFailure`]). Python runs one thread at a time, so Python strategies
//! decide one robot at a time, whatever the thread count; each robot's object and random
//! generator are its own, so results do not depend on the order.

use std::cell::RefCell;
use std::sync::{Mutex, PoisonError};

use numpy::IntoPyArray;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList, PyTuple};
use rand::Rng;
use sim_core::agent::{Ctx, Needs, Params, RobotRng, Strategy, StrategyFailure, StrategyRegistry};
use sim_core::glam::DVec2;
use sim_core::spatial::{KnownMap, ObstacleMap, RobotId, TreasureId};
use sim_core::world::{Action, Payload, Recipient, StrategyEvent};

use crate::to_py;

/// The Python strategies registered so far, by name.
static STRATEGIES: Mutex<Vec<(String, Py<PyAny>)>> = Mutex::new(Vec::new());

scoped_tls::scoped_thread_local!(static OBSTACLES: ObstacleMap);
scoped_tls::scoped_thread_local!(static KNOWN: KnownMap);
scoped_tls::scoped_thread_local!(static CALLS: RefCell<Calls>);

/// What a `decide` call asks of its context, applied to it when the call returns.
struct Calls {
    /// Which call of `decide` this is (see [`DECIDE_CALLS`]): a [`Robot`] acts only in its own.
    serial: u64,
    rng: RobotRng,
    out: Vec<Out>,
    /// The goal `decide` published, if it published one (`None` inside: no goal).
    goal: Option<Published>,
    radius_m: f64,
}

/// Calls of a Python `decide` so far, in the whole process: each call's number, given to its
/// [`Calls`] and its [`Robot`], tells a robot kept from an earlier call from the current one.
static DECIDE_CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// A goal a strategy published: a point, or none.
type Published = Option<DVec2>;

/// A message to send, in the order `decide` asked.
enum Out {
    Message(Recipient, Payload),
    KnownMap,
    Note(String),
}

/// Add the strategy classes and functions to the module.
pub(crate) fn add_to(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(pyo3::wrap_pyfunction!(register_strategy, m)?)?;
    m.add_function(pyo3::wrap_pyfunction!(strategies, m)?)?;
    m.add_class::<Robot>()?;
    m.add_class::<Move>()?;
    m.add_class::<MoveTo>()?;
    m.add_class::<Idle>()?;
    m.add_class::<Excavate>()?;
    m.add_class::<Load>()?;
    m.add_class::<Unload>()?;
    m.add_class::<Broadcast>()?;
    m.add_class::<SendTo>()?;
    Ok(())
}

/// Make `factory(params: dict) -> object with decide(self, robot)` the strategy `name`, for
/// configs to name in a group's `strategy` (replacing an earlier Python strategy of that
/// name). `params` holds the group's `<param>` values as strings. The object may say what
/// it perceives with a `needs` attribute (a collection of `"known_map"`, `"obstacles"`,
/// `"robots"`, `"treasures"`, `"messages"`; all by default).
#[pyfunction]
fn register_strategy(name: &str, factory: Bound<'_, PyAny>) -> PyResult<()> {
    let word = |c: char| c.is_alphanumeric() || c == '_' || c == '-';
    if name.is_empty() || !name.chars().all(word) {
        return Err(to_py(format!(
            "register_strategy('{name}', …): a strategy's name is a word of letters, digits, '_' and '-', as configs name it"
        )));
    }
    if !factory.is_callable() {
        return Err(to_py(format!(
            "register_strategy('{name}', …): the factory is not callable"
        )));
    }
    if StrategyRegistry::with_builtins().contains(name) {
        return Err(to_py(format!(
            "register_strategy('{name}', …): '{name}' is a built-in strategy; choose another name"
        )));
    }
    let mut list = STRATEGIES.lock().unwrap_or_else(PoisonError::into_inner);
    list.retain(|(n, _)| n != name);
    list.push((name.to_owned(), factory.unbind()));
    Ok(())
}

/// Every strategy a config can name, built-in or registered from Python: `(name,
/// description)`, sorted by name.
#[pyfunction]
fn strategies() -> Vec<(String, String)> {
    registry()
        .describe()
        .map(|(n, d)| (n.to_owned(), d.to_owned()))
        .collect()
}

/// The built-in strategies and the Python ones registered so far.
pub(crate) fn registry() -> StrategyRegistry {
    let mut registry = StrategyRegistry::with_builtins();
    Python::attach(|py| {
        let list = STRATEGIES.lock().unwrap_or_else(PoisonError::into_inner);
        for (name, factory) in list.iter() {
            let factory = factory.clone_ref(py);
            let description = format!("written in Python ({})", describe(factory.bind(py)));
            registry.register(name, &description, move |params| python_strategy(&factory, params));
        }
    });
    registry
}

/// The factory's qualified name, for `strategies()`.
fn describe(factory: &Bound<'_, PyAny>) -> String {
    factory
        .getattr("__qualname__")
        .and_then(|n| n.extract::<String>())
        .unwrap_or_else(|_| "a callable".to_owned())
}

/// A strategy object from `factory(params)`, checked to have a `decide`.
fn python_strategy(factory: &Py<PyAny>, params: &Params) -> sim_core::Result<Box<dyn Strategy>> {
    Python::attach(|py| {
        let failed = |what: &str, e: &PyErr| sim_core::Error::InvalidParameter(format!("{what}: {}", traceback(py, e)));
        let dict = PyDict::new(py);
        for (k, v) in params.iter() {
            dict.set_item(k, v)
                .map_err(|e| failed("cannot pass the parameters", &e))?;
        }
        let obj = factory
            .call1(py, (dict,))
            .map_err(|e| failed("the Python strategy's factory raised", &e))?;
        let bound = obj.bind(py);
        if !bound.hasattr("decide").unwrap_or(false) {
            return Err(sim_core::Error::InvalidParameter(format!(
                "the Python strategy's factory returned {}, which has no decide(robot) method",
                bound.repr().map_or_else(|_| "an object".to_owned(), |r| r.to_string())
            )));
        }
        let needs = needs_of(bound).map_err(|e| failed("its needs", &e))?;
        Ok(Box::new(PyStrategy { obj, needs }) as Box<dyn Strategy>)
    })
}

/// The perceptions a strategy object asks for in its `needs` attribute (all without one).
fn needs_of(obj: &Bound<'_, PyAny>) -> PyResult<Needs> {
    let Ok(listed) = obj.getattr("needs") else {
        return Ok(Needs::ALL);
    };
    let mut needs = Needs::NONE;
    for item in listed.try_iter()? {
        let name: String = item?.extract()?;
        match name.as_str() {
            "known_map" => needs.known_map = true,
            "obstacles" => needs.obstacles = true,
            "robots" => needs.robots = true,
            "treasures" => needs.treasures = true,
            "messages" => needs.messages = true,
            other => {
                return Err(to_py(format!(
                    "unknown need '{other}' (known: known_map, obstacles, robots, treasures, messages)"
                )));
            }
        }
    }
    Ok(needs)
}

/// A Python exception with its traceback, as Python prints it.
pub(crate) fn traceback(py: Python<'_>, e: &PyErr) -> String {
    let formatted = py.import("traceback").and_then(|tb| {
        tb.call_method1("format_exception", (e.get_type(py), e.value(py), e.traceback(py)))?
            .extract::<Vec<String>>()
    });
    formatted.map_or_else(|_| e.to_string(), |lines| lines.concat().trim_end().to_owned())
}

thread_local! {
    /// Why a Python strategy's object last failed to pickle on this thread: the kernel's
    /// error for a strategy that cannot save its state does not know.
    pub(crate) static PICKLE_FAILURE: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// `e`, an error of saving a run's state, with the reason a Python strategy's object did
/// not pickle, if one did not.
pub(crate) fn with_pickle_failure(e: sim_core::Error) -> PyErr {
    match PICKLE_FAILURE.take() {
        Some(why) => to_py(format!(
            "{e}: checkpoints save a Python strategy with pickle, and its object does not pickle ({why})"
        )),
        None => to_py(e),
    }
}

/// A strategy whose decisions a Python object makes.
struct PyStrategy {
    obj: Py<PyAny>,
    needs: Needs,
}

impl Strategy for PyStrategy {
    fn needs(&self) -> Needs {
        self.needs
    }

    fn decide(&mut self, ctx: &mut Ctx) -> Action {
        let serial = DECIDE_CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let robot = Robot::of(ctx, serial);
        let calls = RefCell::new(Calls {
            serial,
            rng: std::mem::replace(&mut ctx.rng, rand::SeedableRng::seed_from_u64(0)),
            out: Vec::new(),
            goal: None,
            radius_m: ctx.kind.radius_m,
        });
        let decided = {
            let terrain = ctx.terrain();
            CALLS.set(&calls, || match terrain {
                Some(t) => OBSTACLES.set(t.obstacles, || KNOWN.set(t.known, || self.call_decide(robot))),
                None => self.call_decide(robot),
            })
        };
        let Calls { rng, out, goal, .. } = calls.into_inner();
        ctx.rng = rng;
        apply(ctx, out, goal);
        match decided {
            Ok(action) => action,
            Err(reason) => std::panic::resume_unwind(Box::new(StrategyFailure(reason))),
        }
    }

    fn save_state(&self) -> Option<Vec<u8>> {
        Python::attach(|py| {
            let pickled = py
                .import("pickle")
                .and_then(|p| p.call_method1("dumps", (&self.obj,)))
                .and_then(|b| b.extract::<Vec<u8>>());
            pickled.inspect_err(|e| PICKLE_FAILURE.set(Some(e.to_string()))).ok()
        })
    }

    fn restore_state(&mut self, state: &[u8]) -> sim_core::Result<()> {
        Python::attach(|py| {
            let restored = py
                .import("pickle")
                .and_then(|p| p.call_method1("loads", (PyBytes::new(py, state),)));
            match restored {
                Ok(obj) => {
                    self.obj = obj.unbind();
                    Ok(())
                }
                Err(e) => Err(sim_core::Error::InvalidParameter(format!(
                    "a Python strategy's state does not unpickle: {}",
                    traceback(py, &e)
                ))),
            }
        })
    }
}

impl PyStrategy {
    /// `obj.decide(robot)` as an action, or the reason it gave none.
    fn call_decide(&self, robot: Robot) -> Result<Action, String> {
        Python::attach(|py| {
            let (position, speed) = (robot.position, robot.speed_m);
            let returned = self
                .obj
                .call_method1(py, "decide", (robot,))
                .map_err(|e| format!("decide raised\n{}", traceback(py, &e)))?;
            action_of(returned.bind(py), position, speed)
        })
    }
}

/// Send what `decide` asked to send, and set its goal.
fn apply(ctx: &mut Ctx, out: Vec<Out>, goal: Option<Published>) {
    for o in out {
        match o {
            Out::Message(Recipient::Broadcast, p) => ctx.broadcast(p),
            Out::Message(Recipient::Direct(to), p) => ctx.send(to, p),
            Out::KnownMap => ctx.broadcast_known_map(),
            Out::Note(text) => ctx.report(StrategyEvent::Note(text)),
        }
    }
    if let Some(goal) = goal {
        ctx.set_goal(goal);
    }
}

/// The action (and messages) `decide` returned: an action, `None` (idle), or a list of at
/// most one action and any messages.
fn action_of(returned: &Bound<'_, PyAny>, position: DVec2, speed_m: f64) -> Result<Action, String> {
    if returned.is_none() {
        return Ok(Action::Idle);
    }
    if returned.is_instance_of::<PyList>() || returned.is_instance_of::<PyTuple>() {
        let mut action = None;
        for item in returned.try_iter().map_err(|e| e.to_string())? {
            let item = item.map_err(|e| e.to_string())?;
            if queue_message(&item)? {
                continue;
            }
            let Some(one) = one_action(&item, position, speed_m) else {
                return Err(not_an_action(returned, Some(&item)));
            };
            if action.replace(one).is_some() {
                return Err("decide returned more than one action".to_owned());
            }
        }
        return Ok(action.unwrap_or(Action::Idle));
    }
    if queue_message(returned)? {
        return Ok(Action::Idle);
    }
    one_action(returned, position, speed_m).ok_or_else(|| not_an_action(returned, None))
}

/// Why `returned` (or its `item`) is no action: what was returned, and what may be.
fn not_an_action(returned: &Bound<'_, PyAny>, item: Option<&Bound<'_, PyAny>>) -> String {
    let shown = |a: &Bound<'_, PyAny>| a.repr().map_or_else(|_| "an object".to_owned(), |r| r.to_string());
    let what = match item {
        Some(item) => format!(
            "{}, whose item {} is neither an action nor a message",
            shown(returned),
            shown(item)
        ),
        None => shown(returned),
    };
    let numbers = returned.is_instance_of::<PyTuple>()
        && returned.len().is_ok_and(|n| n == 2)
        && returned
            .try_iter()
            .is_ok_and(|mut it| it.all(|x| x.is_ok_and(|x| x.extract::<f64>().is_ok())));
    let hint = if numbers {
        " (to move by dx, dy, return smartteams.Move(dx, dy))"
    } else {
        ""
    };
    format!(
        "decide returned {what}; expected an action (Move, MoveTo, Idle, Excavate, Load, Unload), \
         a message (Broadcast, Send), None, or a list of them{hint}"
    )
}

/// One action object as the kernel's action (`None` if `a` is not one).
fn one_action(a: &Bound<'_, PyAny>, position: DVec2, speed_m: f64) -> Option<Action> {
    if let Ok(m) = a.cast::<Move>() {
        let m = m.get();
        let d = DVec2::new(m.dx, m.dy);
        // `hypot` where the squares overflow (past about 1.3e154 m), as `length` would.
        let len = Some(d.length())
            .filter(|l| l.is_finite())
            .unwrap_or_else(|| m.dx.hypot(m.dy));
        let step = if len > speed_m { d * (speed_m / len) } else { d };
        return Some(Action::MoveTo { to: position + step });
    }
    if let Ok(m) = a.cast::<MoveTo>() {
        let m = m.get();
        return Some(Action::MoveTo {
            to: DVec2::new(m.x, m.y),
        });
    }
    if a.cast::<Idle>().is_ok() {
        return Some(Action::Idle);
    }
    if a.cast::<Unload>().is_ok() {
        return Some(Action::Unload);
    }
    if let Ok(e) = a.cast::<Excavate>() {
        return Some(Action::Excavate {
            treasure: TreasureId::new(e.get().treasure),
        });
    }
    if let Ok(l) = a.cast::<Load>() {
        return Some(Action::Load {
            treasure: TreasureId::new(l.get().treasure),
        });
    }
    None
}

/// Queue `a` if it is a message; whether it was one.
fn queue_message(a: &Bound<'_, PyAny>) -> Result<bool, String> {
    let (to, kind, data) = if let Ok(b) = a.cast::<Broadcast>() {
        let b = b.get();
        (Recipient::Broadcast, b.kind.clone(), b.data.clone())
    } else if let Ok(s) = a.cast::<SendTo>() {
        let s = s.get();
        (Recipient::Direct(RobotId::new(s.to)), s.kind.clone(), s.data.clone())
    } else {
        return Ok(false);
    };
    with_calls(None, |c| c.out.push(Out::Message(to, Payload::Custom { kind, data }))).map_err(|e| e.to_string())?;
    Ok(true)
}

/// Run `f` on the calls of the `decide` running on this thread, if it is the call `serial`
/// (that of the [`Robot`] asking; `None`: any).
fn with_calls<R>(serial: Option<u64>, f: impl FnOnce(&mut Calls) -> R) -> PyResult<R> {
    let current = CALLS.is_set() && serial.is_none_or(|s| CALLS.with(|c| c.borrow().serial) == s);
    if !current {
        return Err(to_py(
            "a Robot's methods work only while its strategy's decide runs, in the call that gave it",
        ));
    }
    Ok(CALLS.with(|c| f(&mut c.borrow_mut())))
}

/// Run `f` on the known map and obstacles of the `decide` call `serial` running on this
/// thread (`None` if its strategy keeps no known map).
fn with_terrain<R>(serial: u64, f: impl FnOnce(&KnownMap, &ObstacleMap) -> R) -> PyResult<Option<R>> {
    with_calls(Some(serial), |_| ())?;
    if !KNOWN.is_set() {
        return Ok(None);
    }
    Ok(Some(KNOWN.with(|k| OBSTACLES.with(|o| f(k, o)))))
}

/// A robot as its Python strategy sees it in one round: a copy of its state and perceptions,
/// and methods that act through its context while `decide` runs.
#[pyclass(module = "smartteams", frozen)]
pub struct Robot {
    /// The `decide` call it was made for (see [`DECIDE_CALLS`]).
    serial: u64,
    /// Its id.
    #[pyo3(get)]
    id: u32,
    /// The round being decided (1-based).
    #[pyo3(get)]
    round: u64,
    position: DVec2,
    /// Energy left.
    #[pyo3(get)]
    energy: f64,
    /// Units carried.
    #[pyo3(get)]
    load: u32,
    kind: sim_core::world::RobotType,
    home: DVec2,
    at_home: bool,
    last: (String, String),
    goal: Option<DVec2>,
    speed_m: f64,
    treasures: Vec<sim_core::agent::SeenTreasure>,
    robots: Vec<(u32, DVec2, String)>,
    /// The round's inbox: picks from the shared mail bag, no copies.
    messages: sim_core::world::Inbox,
}

impl Robot {
    /// The copy of `ctx` a Python strategy gets in `decide` call `serial`.
    fn of(ctx: &Ctx, serial: u64) -> Self {
        let types = ctx.types();
        Self {
            serial,
            id: ctx.me.id.get(),
            round: ctx.round,
            position: ctx.position(),
            energy: ctx.me.energy,
            load: ctx.me.load(),
            kind: ctx.kind.clone(),
            home: ctx.home().center(),
            at_home: ctx.home().contains(ctx.position()),
            last: (
                ctx.me.last_action.0.name().to_owned(),
                format!("{:?}", ctx.last_outcome()).to_lowercase(),
            ),
            goal: ctx.goal(),
            speed_m: ctx.kind.speed_m_per_round,
            treasures: ctx.treasures_in_view().to_vec(),
            robots: ctx
                .robots_in_view()
                .iter()
                .map(|r| (r.id.get(), r.position, types[r.type_index].name.clone()))
                .collect(),
            messages: ctx.messages().clone(),
        }
    }
}

// Python calls these as methods of the robot it got, though the ones acting through the
// context reach it through the thread's scope rather than `self`.
#[allow(clippy::unused_self)]
#[pymethods]
impl Robot {
    /// Position `(x, y)`, metres.
    #[getter]
    fn position(&self) -> (f64, f64) {
        (self.position.x, self.position.y)
    }
    /// x, metres.
    #[getter]
    fn x(&self) -> f64 {
        self.position.x
    }
    /// y, metres.
    #[getter]
    fn y(&self) -> f64 {
        self.position.y
    }
    /// The robot type's name.
    #[getter]
    fn r#type(&self) -> String {
        self.kind.name.clone()
    }
    /// Longest move per round, metres.
    #[getter]
    fn speed_m(&self) -> f64 {
        self.speed_m
    }
    /// View radius, metres.
    #[getter]
    fn view_radius_m(&self) -> f64 {
        self.kind.view_radius_m
    }
    /// Communication radius, metres.
    #[getter]
    fn comm_radius_m(&self) -> f64 {
        self.kind.comm_radius_m
    }
    /// Body radius, metres.
    #[getter]
    fn radius_m(&self) -> f64 {
        self.kind.radius_m
    }
    /// Energy when full.
    #[getter]
    fn energy_capacity(&self) -> f64 {
        self.kind.energy_capacity
    }
    /// Units it can carry.
    #[getter]
    fn carry_capacity(&self) -> u32 {
        self.kind.carry_capacity
    }
    /// Units it digs per round (0: it cannot dig).
    #[getter]
    fn excavation_per_round(&self) -> u32 {
        self.kind.excavation_per_round
    }
    /// The home base's centre `(x, y)`.
    #[getter]
    fn home(&self) -> (f64, f64) {
        (self.home.x, self.home.y)
    }
    /// Whether it is inside the home base.
    #[getter]
    fn at_home(&self) -> bool {
        self.at_home
    }
    /// Last round's action (`"idle"`, `"move"`, `"excavate"`, `"load"`, `"unload"`).
    #[getter]
    fn last_action(&self) -> String {
        self.last.0.clone()
    }
    /// What came of it (`"done"`, `"trimmed"`, `"refused"`).
    #[getter]
    fn last_outcome(&self) -> String {
        self.last.1.clone()
    }
    /// The goal it publishes, if any.
    #[getter]
    fn goal(&self) -> Option<(f64, f64)> {
        self.goal.map(|g| (g.x, g.y))
    }
    /// Treasures in view: dicts of `id`, `x`, `y`, `buried`, `loose`.
    #[getter]
    fn treasures_in_view<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.treasures
            .iter()
            .map(|t| {
                let d = PyDict::new(py);
                d.set_item("id", t.id.get())?;
                d.set_item("x", t.position.x)?;
                d.set_item("y", t.position.y)?;
                d.set_item("buried", t.buried)?;
                d.set_item("loose", t.loose)?;
                Ok(d)
            })
            .collect()
    }
    /// Robots in view: dicts of `id`, `x`, `y`, `type`.
    #[getter]
    fn robots_in_view<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.robots
            .iter()
            .map(|(id, p, kind)| {
                let d = PyDict::new(py);
                d.set_item("id", id)?;
                d.set_item("x", p.x)?;
                d.set_item("y", p.y)?;
                d.set_item("type", kind)?;
                Ok(d)
            })
            .collect()
    }
    /// Messages delivered this round, in sending order: dicts with `from` and `kind`
    /// (`"position"`, `"sightings"`, `"known_map"`, `"claim"`, or a custom message's kind)
    /// and what the kind carries (`data` for custom messages).
    #[getter]
    fn messages<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.messages
            .iter()
            .map(|m| message_dict(py, m.from, &m.payload))
            .collect()
    }

    /// A uniform random number in [0, 1) from this robot's generator (seeded by run seed,
    /// robot and round: the same in every run of the same seed).
    fn random(&self) -> PyResult<f64> {
        with_calls(Some(self.serial), |c| c.rng.random::<f64>())
    }
    /// A uniform random number in [a, b).
    fn uniform(&self, a: f64, b: f64) -> PyResult<f64> {
        if !(a < b && a.is_finite() && b.is_finite()) {
            return Err(to_py(format!("uniform({a}, {b}): needs finite a < b")));
        }
        with_calls(Some(self.serial), |c| c.rng.random_range(a..b))
    }
    /// A uniform random integer in [a, b], both included.
    fn randint(&self, a: i64, b: i64) -> PyResult<i64> {
        if a > b {
            return Err(to_py(format!("randint({a}, {b}): needs a ≤ b")));
        }
        with_calls(Some(self.serial), |c| c.rng.random_range(a..=b))
    }
    /// True with probability `p`.
    fn random_bool(&self, p: f64) -> PyResult<bool> {
        if !(0.0..=1.0).contains(&p) {
            return Err(to_py(format!("random_bool({p}): needs 0 ≤ p ≤ 1")));
        }
        with_calls(Some(self.serial), |c| c.rng.random_bool(p))
    }

    /// Whether the point is in the robot's known map (False without one).
    fn is_known(&self, x: f64, y: f64) -> PyResult<bool> {
        Ok(with_terrain(self.serial, |k, _| k.is_known(DVec2::new(x, y)))?.unwrap_or(false))
    }
    /// Whether a robot of this size fits at the point: `None` where it is not known.
    fn is_free(&self, x: f64, y: f64) -> PyResult<Option<bool>> {
        let radius = with_calls(Some(self.serial), |c| c.radius_m)?;
        let p = DVec2::new(x, y);
        Ok(with_terrain(self.serial, |k, o| k.is_known(p).then(|| o.is_disc_free(p, radius)))?.flatten())
    }
    /// Whether it could move in a straight line from where it is to `(x, y)`: `None` unless
    /// both ends are known.
    fn can_move(&self, x: f64, y: f64) -> PyResult<Option<bool>> {
        let radius = with_calls(Some(self.serial), |c| c.radius_m)?;
        let (a, b) = (self.position, DVec2::new(x, y));
        Ok(with_terrain(self.serial, |k, o| {
            (k.is_known(a) && k.is_known(b)).then(|| o.is_swept_disc_free(a, b, radius))
        })?
        .flatten())
    }
    /// The `cells × cells` window of its known map centred on it: `uint8`, 0 unknown, 1
    /// free, 2 blocked (and beyond the map's edge); row 0 the southern row. All 0 without a
    /// known map.
    #[pyo3(signature = (cells=11))]
    fn known_patch<'py>(&self, py: Python<'py>, cells: u32) -> PyResult<Bound<'py, numpy::PyArray2<u8>>> {
        if cells == 0 || cells > 1001 {
            return Err(to_py(format!("known_patch(cells={cells}): needs 1 to 1001 cells")));
        }
        let n = cells as usize;
        let mut out = Vec::with_capacity(n * n);
        if with_terrain(self.serial, |k, o| {
            crate::grids::patch(k, o, self.position, cells, &mut out);
        })?
        .is_none()
        {
            out.resize(n * n, crate::grids::UNKNOWN);
        }
        Ok(Array2::from_shape_vec((n, n), out).map_err(to_py)?.into_pyarray(py))
    }

    /// Send `data` under `kind` to every robot in range (delivered next round).
    fn broadcast(&self, kind: String, data: Vec<u8>) -> PyResult<()> {
        with_calls(Some(self.serial), |c| {
            c.out
                .push(Out::Message(Recipient::Broadcast, Payload::Custom { kind, data }));
        })
    }
    /// Send `data` under `kind` to robot `to`, if it is in range.
    fn send(&self, to: u32, kind: String, data: Vec<u8>) -> PyResult<()> {
        with_calls(Some(self.serial), |c| {
            c.out.push(Out::Message(
                Recipient::Direct(RobotId::new(to)),
                Payload::Custom { kind, data },
            ));
        })
    }
    /// Share its known map with every robot in range (merged into theirs on receipt).
    fn share_known_map(&self) -> PyResult<()> {
        with_calls(Some(self.serial), |c| c.out.push(Out::KnownMap))
    }
    /// Publish a goal (drawn by viewers; kept until changed), or none (no arguments).
    #[pyo3(signature = (x=None, y=None))]
    fn set_goal(&self, x: Option<f64>, y: Option<f64>) -> PyResult<()> {
        let goal = match (x, y) {
            (None, None) => None,
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Some(DVec2::new(x, y)),
            _ => {
                let shown = |v: Option<f64>| v.map_or_else(|| "None".to_owned(), |v| v.to_string());
                return Err(to_py(format!(
                    "set_goal(x, y) takes two finite numbers, or none to clear the goal; got ({}, {})",
                    shown(x),
                    shown(y)
                )));
            }
        };
        with_calls(Some(self.serial), |c| c.goal = Some(goal))
    }
    /// Write `text` to the event log.
    fn note(&self, text: String) -> PyResult<()> {
        with_calls(Some(self.serial), |c| c.out.push(Out::Note(text)))
    }

    fn __repr__(&self) -> String {
        format!(
            "<smartteams.Robot {} ({}) at ({:.2}, {:.2}), round {}>",
            self.id, self.kind.name, self.position.x, self.position.y, self.round
        )
    }
}

/// A delivered message as a dict.
fn message_dict<'py>(py: Python<'py>, from: RobotId, payload: &Payload) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("from", from.get())?;
    match payload {
        Payload::Custom { kind, data } => {
            d.set_item("kind", kind)?;
            d.set_item("data", PyBytes::new(py, data))?;
        }
        Payload::Position { position, goal } => {
            d.set_item("kind", "position")?;
            d.set_item("x", position.x)?;
            d.set_item("y", position.y)?;
            d.set_item("goal", goal.map(|g| (g.x, g.y)))?;
        }
        Payload::Sightings(s) => {
            d.set_item("kind", "sightings")?;
            let seen: Vec<(u32, f64, f64, u32, u32)> = s
                .iter()
                .map(|s| (s.treasure.get(), s.position.x, s.position.y, s.buried, s.loose))
                .collect();
            d.set_item("treasures", seen)?;
        }
        Payload::KnownMap(_) => d.set_item("kind", "known_map")?,
        Payload::Claim {
            treasure,
            task,
            distance_m,
        } => {
            d.set_item("kind", "claim")?;
            d.set_item("treasure", treasure.get())?;
            d.set_item("task", format!("{task:?}").to_lowercase())?;
            d.set_item("distance_m", f64::from(*distance_m))?;
        }
    }
    Ok(d)
}

/// Move by `(dx, dy)` metres (shortened to the robot's speed if longer).
#[pyclass(module = "smartteams", frozen)]
pub struct Move {
    /// East, metres.
    #[pyo3(get)]
    dx: f64,
    /// North, metres.
    #[pyo3(get)]
    dy: f64,
}

#[pymethods]
impl Move {
    #[new]
    fn new(dx: f64, dy: f64) -> Self {
        Self { dx, dy }
    }
    fn __repr__(&self) -> String {
        format!("Move({}, {})", self.dx, self.dy)
    }
    /// What `pickle` makes it again from (strategies that keep actions checkpoint).
    fn __getnewargs__(&self) -> (f64, f64) {
        (self.dx, self.dy)
    }
}

/// Move in a straight line towards `(x, y)`, as far as speed, energy, obstacles and other
/// robots allow.
#[pyclass(module = "smartteams", frozen)]
pub struct MoveTo {
    /// Target x, metres.
    #[pyo3(get)]
    x: f64,
    /// Target y, metres.
    #[pyo3(get)]
    y: f64,
}

#[pymethods]
impl MoveTo {
    #[new]
    fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }
    fn __repr__(&self) -> String {
        format!("MoveTo({}, {})", self.x, self.y)
    }
    /// What `pickle` makes it again from.
    fn __getnewargs__(&self) -> (f64, f64) {
        (self.x, self.y)
    }
}

/// Do nothing this round (idle energy is still spent).
#[pyclass(module = "smartteams", frozen)]
pub struct Idle;

#[pymethods]
impl Idle {
    #[new]
    fn new() -> Self {
        Self
    }
    #[allow(clippy::unused_self)] // Python's repr is a method
    fn __repr__(&self) -> &'static str {
        "Idle()"
    }
}

/// Dig at treasure `treasure` (within reach; the robot's type must be able to dig).
#[pyclass(module = "smartteams", frozen)]
pub struct Excavate {
    /// The treasure's id.
    #[pyo3(get)]
    treasure: u32,
}

#[pymethods]
impl Excavate {
    #[new]
    fn new(treasure: u32) -> Self {
        Self { treasure }
    }
    fn __repr__(&self) -> String {
        format!("Excavate({})", self.treasure)
    }
    /// What `pickle` makes it again from.
    fn __getnewargs__(&self) -> (u32,) {
        (self.treasure,)
    }
}

/// Load dug units of treasure `treasure` (within reach; as many as fit and lie there).
#[pyclass(module = "smartteams", frozen)]
pub struct Load {
    /// The treasure's id.
    #[pyo3(get)]
    treasure: u32,
}

#[pymethods]
impl Load {
    #[new]
    fn new(treasure: u32) -> Self {
        Self { treasure }
    }
    fn __repr__(&self) -> String {
        format!("Load({})", self.treasure)
    }
    /// What `pickle` makes it again from.
    fn __getnewargs__(&self) -> (u32,) {
        (self.treasure,)
    }
}

/// Drop the cargo in the home base (delivered).
#[pyclass(module = "smartteams", frozen)]
pub struct Unload;

#[pymethods]
impl Unload {
    #[new]
    fn new() -> Self {
        Self
    }
    #[allow(clippy::unused_self)] // Python's repr is a method
    fn __repr__(&self) -> &'static str {
        "Unload()"
    }
}

/// A message to every robot in range: `data` (bytes) under `kind`, delivered next round.
/// Returned from `decide` (alone or in a list with the round's action).
#[pyclass(module = "smartteams", frozen)]
pub struct Broadcast {
    /// The tag receivers recognise.
    #[pyo3(get)]
    kind: String,
    /// The content.
    data: Vec<u8>,
}

#[pymethods]
impl Broadcast {
    #[new]
    #[pyo3(signature = (kind, data=Vec::new()))]
    fn new(kind: String, data: Vec<u8>) -> Self {
        Self { kind, data }
    }
    /// The content.
    #[getter]
    fn data<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.data)
    }
    fn __repr__(&self) -> String {
        format!("Broadcast({:?}, <{} bytes>)", self.kind, self.data.len())
    }
    /// What `pickle` makes it again from.
    fn __getnewargs__<'py>(&self, py: Python<'py>) -> (String, Bound<'py, PyBytes>) {
        (self.kind.clone(), PyBytes::new(py, &self.data))
    }
}

/// A message to robot `to` if it is in range: `data` (bytes) under `kind`.
#[pyclass(module = "smartteams", name = "Send", frozen)]
pub struct SendTo {
    /// The receiver's id.
    #[pyo3(get)]
    to: u32,
    /// The tag the receiver recognises.
    #[pyo3(get)]
    kind: String,
    /// The content.
    data: Vec<u8>,
}

#[pymethods]
impl SendTo {
    #[new]
    #[pyo3(signature = (to, kind, data=Vec::new()))]
    fn new(to: u32, kind: String, data: Vec<u8>) -> Self {
        Self { to, kind, data }
    }
    /// The content.
    #[getter]
    fn data<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.data)
    }
    fn __repr__(&self) -> String {
        format!("Send({}, {:?}, <{} bytes>)", self.to, self.kind, self.data.len())
    }
    /// What `pickle` makes it again from.
    fn __getnewargs__<'py>(&self, py: Python<'py>) -> (u32, String, Bound<'py, PyBytes>) {
        (self.to, self.kind.clone(), PyBytes::new(py, &self.data))
    }
}
