//! Keyboard driving for `orsa teleop`: arrows or WASD change the velocity, space stops, q quits.

use std::time::Duration;

/// Speed steps and limits of keyboard driving.
const DV: f64 = 0.05;
const DW: f64 = 0.2;
const MAX_V: f64 = 0.5;
const MAX_W: f64 = 1.2;

/// What a key does to the command (v, omega); `None` quits.
pub(crate) fn apply_key(code: crossterm::event::KeyCode, (v, w): (f64, f64)) -> Option<(f64, f64)> {
    use crossterm::event::KeyCode as K;
    Some(match code {
        K::Up | K::Char('w' | 'W') => ((v + DV).min(MAX_V), w),
        K::Down | K::Char('s' | 'S') => ((v - DV).max(-MAX_V), w),
        K::Left | K::Char('a' | 'A') => (v, (w + DW).min(MAX_W)),
        K::Right | K::Char('d' | 'D') => (v, (w - DW).max(-MAX_W)),
        K::Char(' ') => (0.0, 0.0),
        K::Char('q' | 'Q') | K::Esc => return None,
        _ => (v, w),
    })
}

/// Restores the terminal when dropped, whatever happens.
struct RawMode;

impl Drop for RawMode {
    fn drop(&mut self) {
        let _ = crossterm::terminal::disable_raw_mode();
    }
}

/// Reads the keyboard and sends the current command every `period` through `send` until q.
pub(crate) async fn drive(
    period: Duration,
    send: impl Fn(f64, f64) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    use crossterm::event::{Event, KeyEventKind, poll, read};
    crossterm::terminal::enable_raw_mode().map_err(|e| {
        anyhow::anyhow!("teleop needs a terminal ({e}); use --send V,OMEGA --for SECS to script it")
    })?;
    let _raw = RawMode;
    eprint!("teleop: arrows/WASD drive, space stops, q quits\r\n");
    let mut cmd = (0.0, 0.0);
    let mut tick = tokio::time::interval(period);
    loop {
        tick.tick().await;
        // Drain the keys pressed since the last tick without blocking the runtime.
        while poll(Duration::ZERO)? {
            if let Event::Key(k) = read()?
                && k.kind != KeyEventKind::Release
            {
                match apply_key(k.code, cmd) {
                    Some(next) => cmd = next,
                    None => {
                        send(0.0, 0.0)?;
                        eprint!("teleop: stopped, control given back\r\n");
                        return Ok(());
                    }
                }
            }
        }
        send(cmd.0, cmd.1)?;
        eprint!("\rv {:+.2} m/s  omega {:+.2} rad/s   ", cmd.0, cmd.1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crossterm::event::KeyCode as K;

    #[test]
    fn keys_step_clamp_stop_and_quit() {
        let mut c = (0.0, 0.0);
        for _ in 0..20 {
            c = apply_key(K::Up, c).expect("drive");
        }
        assert_eq!(c.0, MAX_V, "clamped");
        c = apply_key(K::Char('a'), c).expect("turn");
        assert!((c.1 - DW).abs() < 1e-12);
        assert_eq!(apply_key(K::Char(' '), c), Some((0.0, 0.0)));
        assert_eq!(apply_key(K::Char('q'), c), None);
        assert_eq!(apply_key(K::Char('x'), c), Some(c), "other keys change nothing");
    }
}
