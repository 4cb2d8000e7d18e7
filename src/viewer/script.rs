//! Scripted input for the viewer ([`super::ViewerOptions::script`]): key presses, punctures and drags replayed at
//! given frames, for tests and CI (`fissure view --script "20:puncture-body:0;25:key:f"`).

/// A scripted input (see [`super::ViewerOptions::script`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// A key press (the characters of the key table, or `" "` for space).
    Key(String),
    /// A right click at pixel `(x, y)`: punctures the body there.
    Puncture(f32, f32),
    /// A right click on the centre of body `b` as seen from the camera.
    PunctureBody(usize),
    /// A left press on the centre of body `b`, then the cursor moved by `(dx, dy)` pixels and held there: the
    /// grabbed mass point is pulled towards it (past a cloth's strength, it tears).
    DragBody(usize, f32, f32),
    /// The left button released (ends a drag).
    Release,
}

impl std::str::FromStr for Action {
    type Err = String;

    /// `key:f`, `puncture:480,270`, `puncture-body:0`, `drag-body:0,0,300` or `release:`.
    fn from_str(s: &str) -> Result<Action, String> {
        let (kind, arg) = s.split_once(':').ok_or_else(|| {
            format!("{s:?}: want key:K, puncture:X,Y, puncture-body:B, drag-body:B,DX,DY or release:")
        })?;
        match kind {
            "key" => Ok(Action::Key(arg.to_string())),
            "puncture" => {
                let (x, y) = arg.split_once(',').ok_or_else(|| format!("{s:?}: want puncture:X,Y"))?;
                let p = |v: &str| v.trim().parse::<f32>().map_err(|_| format!("{s:?}: {v:?} is not a pixel"));
                Ok(Action::Puncture(p(x)?, p(y)?))
            }
            "puncture-body" => arg.parse().map(Action::PunctureBody).map_err(|_| format!("{s:?}: not a body index")),
            "drag-body" => {
                let v: Vec<&str> = arg.split(',').map(str::trim).collect();
                let bad = || format!("{s:?}: want drag-body:B,DX,DY");
                let [b, dx, dy] = v[..] else { return Err(bad()) };
                let p = |v: &str| v.parse::<f32>().map_err(|_| bad());
                Ok(Action::DragBody(b.parse().map_err(|_| bad())?, p(dx)?, p(dy)?))
            }
            "release" => Ok(Action::Release),
            other => Err(format!("{s:?}: unknown action {other:?}")),
        }
    }
}
