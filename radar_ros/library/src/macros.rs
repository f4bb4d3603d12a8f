//! `once!`, `whenever!` and `waitfor!`: RADAR's statements in the paper's syntax.
//!
//! Used as statements inside an async function that returns `Result<_, E>` with
//! `E: From<radar_ros::Error>`, `once!` and `whenever!` arm a connection and bind its guard to the enclosing
//! block: the connection lives until the block ends (normally, by `?`, or by a panic unwinding).
//!
//! ```no_run
//! use radar_ros::{once, whenever, waitfor, msg::Empty};
//! # async fn f(radar: radar_ros::Radar, start_event: radar_ros::EventHandle, end_event: radar_ros::EventHandle,
//! #            count_up: radar_ros::ResponseHandle) -> radar_ros::Result<()> {
//! once!(radar, start_event start count_up until end_event);   // Listing 1, line 22
//! whenever!(radar, end_event => |_: Empty| println!("end!")); // an anonymous slot
//! let out: Empty = waitfor!(radar, (count_up.reference().exited()));
//! # Ok(()) }
//! ```
//!
//! A source written as a name (`start_event`) means that event's `triggered`; any other signal is written
//! in parentheses: `(count_up.reference().exited())`. The forms are those of the paper: `E start R`,
//! `E start R until U` (U interrupts R, but only runs this statement started: see [`crate::connections::statement`]),
//! `E interrupt R`, `E exit R`, and `E => closure` for an anonymous slot.

/// Turns a statement's source into a [`Signal`](crate::Signal): `name` is an event, `(expr)` any signal.
#[doc(hidden)]
#[macro_export]
macro_rules! __radar_signal {
    (($sig:expr)) => {
        $sig
    };
    ($event:ident) => {
        $event.triggered()
    };
}

/// Shared body of `once!` and `whenever!`.
#[doc(hidden)]
#[macro_export]
macro_rules! __radar_statement {
    ($kind:ident, $radar:expr, $src:tt start $resp:ident until $until:tt) => {
        let _radar_connection = $radar
            .$kind($crate::__radar_signal!($src))
            .start(&$resp)
            .until($crate::__radar_signal!($until))
            .await?;
    };
    ($kind:ident, $radar:expr, $src:tt start $resp:ident) => {
        let _radar_connection = $radar
            .$kind($crate::__radar_signal!($src))
            .start(&$resp)
            .await?;
    };
    ($kind:ident, $radar:expr, $src:tt interrupt $resp:ident) => {
        let _radar_connection = $radar
            .$kind($crate::__radar_signal!($src))
            .interrupt(&$resp)
            .await?;
    };
    ($kind:ident, $radar:expr, $src:tt exit $resp:ident) => {
        let _radar_connection = $radar
            .$kind($crate::__radar_signal!($src))
            .exit(&$resp)
            .await?;
    };
    ($kind:ident, $radar:expr, $src:tt => $slot:expr) => {
        let _radar_connection = $radar
            .$kind($crate::__radar_signal!($src))
            .call($slot)
            .await?;
    };
}

/// `once!(radar, E start R [until U])`, `once!(radar, E interrupt R)`, `once!(radar, E exit R)`,
/// `once!(radar, E => |payload: T| ...)`: a connection that delivers one signal, for the rest of the block.
///
/// Only the paper's forms are statements: `until` goes with `start` alone.
///
/// ```compile_fail
/// # async fn f(radar: radar_ros::Radar, bumper: radar_ros::EventHandle, stop: radar_ros::EventHandle,
/// #            nav: radar_ros::ResponseHandle) -> radar_ros::Result<()> {
/// radar_ros::once!(radar, bumper interrupt nav until stop);
/// # Ok(()) }
/// ```
#[macro_export]
macro_rules! once {
    ($radar:expr, $($rest:tt)+) => {
        $crate::__radar_statement!(once, $radar, $($rest)+)
    };
}

/// `whenever!(radar, E start R [until U])` and the other forms of [`once!`]: a connection that delivers every
/// signal, for the rest of the block.
#[macro_export]
macro_rules! whenever {
    ($radar:expr, $($rest:tt)+) => {
        $crate::__radar_statement!(whenever, $radar, $($rest)+)
    };
}

/// `waitfor!(radar, E)` or `waitfor!(radar, (signal))`: the payload of the next signal (its type inferred),
/// as [`Radar::waitfor`](crate::Radar::waitfor); `waitfor!(radar, E, timeout)` bounds the whole wait.
#[macro_export]
macro_rules! waitfor {
    ($radar:expr, $src:tt) => {
        $radar.waitfor($crate::__radar_signal!($src)).await?
    };
    ($radar:expr, $src:tt, $timeout:expr) => {
        $radar
            .waitfor($crate::__radar_signal!($src))
            .timeout($timeout)
            .await?
    };
}
