//! Which setups a run machines (issue 36): orientation selection for the tools' reach,
//! and, where a finishing run could choose its setups either for the roughing end mill's
//! reach or for the shorter finishing ball's, the choice between the two sets by what
//! each leaves unreached ([`choose_setups`]).

use super::api::MillOptions;
use super::finish_scope::prismatic_share;
use super::stock::StockBody;
use super::tooling::Tooling;
use crate::geom::{Aabb, Mesh, Point3};
use crate::orient::{
    OrientError, OrientOptions, OrientationResult, ToolReach, Unreached, select_orientations,
    select_orientations_in_stock, unreached,
};

/// Stock samples of the stock-removal term of orientation selection: a grid of about 32^3
/// cells over the stock, so that a slab of stock one cell thick under a flat part counts.
const STOCK_SAMPLES: usize = 32 * 32 * 32;

/// The least [`prismatic_share`] of a part whose setups are chosen for the roughing's
/// reach with finishing on, without comparing the ball's: the roughing, cut to size, makes
/// most of such a part and the finisher only its sculpted rest. On the 16 parts of the
/// finishing table the shares are 1.0-0.89 (the shop parts, the gear, LetterBlock,
/// text_on_cube, example007 and 016) or 0.73-0.21 (Advanced_offset, example001, 002, 004,
/// 006): below, both sets are planned and compared ([`choose_setups`]).
pub(super) const PRISMATIC_PART: f64 = 0.75;

/// The reaches a run's setups are chosen for: the roughing's, and, where the run finishes
/// a part less prismatic than [`PRISMATIC_PART`] with a ball that reaches less deep, the
/// ball's (`None` otherwise: the roughing's set only).
#[derive(Clone, Copy, Debug)]
pub(super) struct Reaches {
    pub rough: Option<ToolReach>,
    pub ball: Option<ToolReach>,
}

impl Reaches {
    /// The reaches of a run's `tooling` over `stock` ([`Tooling::reach`], tool-aware where
    /// [`MillOptions::tool_aware_reach`] says, the ball's where it finishes), a tool
    /// reaching a surface it comes within `slack` of ([`ToolReach::slack`]).
    pub(super) fn of_tooling(
        part: &Mesh,
        tooling: &Tooling,
        stock: Aabb,
        slack: f64,
        opts: &MillOptions,
    ) -> Self {
        let (finishing, tool_aware) = (opts.finish.is_some(), opts.tool_aware_reach);
        let reach = |f: bool| tooling.reach(stock, f, tool_aware).map(|r| r.with_slack(slack));
        Self::new(part, reach(false), reach(true), finishing)
    }

    /// `rough` and `ball` are the tools' reaches ([`Tooling::reach`](super::tooling::Tooling::reach)).
    pub(super) fn new(
        part: &Mesh,
        rough: Option<ToolReach>,
        ball: Option<ToolReach>,
        finishing: bool,
    ) -> Self {
        let ball = match (rough, ball) {
            (Some(r), Some(b))
                if finishing && b.depth < r.depth && prismatic_share(part) < PRISMATIC_PART =>
            {
                Some(b)
            }
            _ => None,
        };
        Self { rough, ball }
    }
}

/// What [`choose_setups`] compared: what each candidate set leaves unreached, and which
/// it took.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SetupChoice {
    /// The set chosen for the roughing's reach.
    pub rough: Unreached,
    /// The set chosen for the ball's.
    pub ball: Unreached,
    /// Whether the ball's set was taken.
    pub took_ball: bool,
}

/// Orientation selection, with the stock-removal term over `stock` where it has samples.
fn select_setups(
    part: &Mesh,
    stock: &[Point3],
    oopts: &OrientOptions,
) -> Result<OrientationResult, OrientError> {
    if stock.is_empty() {
        select_orientations(part, oopts)
    } else {
        select_orientations_in_stock(part, stock, oopts)
    }
}

/// The setups of a run: those orientation selection chooses for `reaches.rough` and,
/// where `reaches.ball` is set, those it chooses for the ball's reach too, the better of
/// the two by [`ball_set_better`] (ties, and the same axes in another order, to the
/// roughing's). Both sets are scored on the same samples ([`unreached`]). Orientation
/// selection uses the stock-removal term where `stock_removal` asks for it and the part
/// is closed: an open mesh has no inside to tell stock from part, and a setup added to
/// reach the "stock" behind a missing face would cut into the part through it.
pub(super) fn choose_setups(
    part: &Mesh,
    body: &StockBody,
    oopts: &OrientOptions,
    reaches: Reaches,
    stock_removal: bool,
) -> Result<(OrientationResult, Option<SetupChoice>), OrientError> {
    let closed = crate::geom::report(part).closed;
    let stock = if stock_removal && closed { body.samples(STOCK_SAMPLES) } else { Vec::new() };
    let rough = select_setups(part, &stock, &OrientOptions { reach: reaches.rough, ..*oopts })?;
    let Some(ball_reach) = reaches.ball else { return Ok((rough, None)) };
    let ball = select_setups(part, &stock, &OrientOptions { reach: Some(ball_reach), ..*oopts })?;
    if ball.directions.len() == rough.directions.len()
        && ball.directions.iter().all(|d| rough.directions.contains(d))
    {
        return Ok((rough, None));
    }
    // What neither set's tools reach is counted on material the roughing removes (the
    // stock's grid, or none for an open mesh, whose inside is unknown).
    let material = if closed { body.samples(STOCK_SAMPLES) } else { Vec::new() };
    let sets = [rough.directions.as_slice(), ball.directions.as_slice()];
    let scores = unreached(part, &material, &sets, oopts, Some(ball_reach), reaches.rough)?;
    let choice =
        SetupChoice { rough: scores[0], ball: scores[1], took_ball: ball_set_better(&scores[1], &scores[0]) };
    Ok((if choice.took_ball { ball } else { rough }, Some(choice)))
}

/// Whether the ball's set `ball` leaves less unreached than the roughing's `rough`: the
/// material left (as a share of the part's stock samples, about the IoU it costs) plus the
/// surface the ball reaches from no setup (as a share of the surface samples), strictly
/// less. On example004 (a cube less a sphere) the ball's set leaves 1.58 + 0.376 against
/// 2.74 + 0.376 (the roughing's set, chosen by a search that stops at a local optimum,
/// leaves more stock even within the roughing's reach); on example006 and example002 the
/// two sets leave the same. With the tool-aware reach ([`MillOptions::tool_aware_reach`])
/// Advanced_offset's roughing set leaves 865 of 16,384 surface samples that no ball
/// fitting there reaches, the ball's none, and example004's roughing set 1.40 + 0.376
/// (2,280 stock samples for 1,632 part samples at 128^3) against the ball's 1.58 + 0.376.
pub(super) fn ball_set_better(ball: &Unreached, rough: &Unreached) -> bool {
    ball.stock_fraction() + ball.surface_fraction() < rough.stock_fraction() + rough.surface_fraction()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn left(surface: usize, stock: usize) -> Unreached {
        Unreached { surface, surface_samples: 1000, stock, material: 4000, part: 2000 }
    }

    #[test]
    fn the_ball_set_is_taken_only_where_it_leaves_strictly_less() {
        // Equal: the roughing's.
        assert!(!ball_set_better(&left(10, 100), &left(10, 100)));
        // Less stock (a share of the part's samples) or less surface: the ball's.
        assert!(ball_set_better(&left(10, 50), &left(10, 100)));
        assert!(ball_set_better(&left(5, 100), &left(10, 100)));
        // 2 % of the surface more against 5 % of the part's volume less: the ball's; the
        // other way round, the roughing's.
        assert!(ball_set_better(&left(30, 0), &left(10, 100)));
        assert!(!ball_set_better(&left(10, 100), &left(30, 0)));
    }

    #[test]
    fn only_a_finishing_run_on_a_sculpted_part_with_a_shorter_ball_plans_two_sets() {
        let stock = crate::geom::Aabb::new(Point3::origin(), Point3::new(10.0, 10.0, 10.0));
        // A cube is wholly prismatic: the roughing's set only.
        let cube = Mesh::cuboid(&stock).unwrap();
        let at = |depth: f64| Some(ToolReach::new(stock, depth));
        assert!(Reaches::new(&cube, at(30.0), at(20.0), true).ball.is_none());
        // An octahedron (no face along or square to an axis) is sculpted.
        let v = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let t = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        let octa = Mesh::new(
            v.iter().map(|p| Point3::new(5.0 + 4.0 * p[0], 5.0 + 4.0 * p[1], 5.0 + 4.0 * p[2])).collect(),
            t.to_vec(),
        )
        .unwrap();
        let r = Reaches::new(&octa, at(30.0), at(20.0), true);
        assert_eq!(r.ball.map(|b| b.depth), Some(20.0));
        assert_eq!(r.rough.map(|b| b.depth), Some(30.0));
        assert!(Reaches::new(&octa, at(30.0), at(20.0), false).ball.is_none());
        assert!(Reaches::new(&octa, at(30.0), at(30.0), true).ball.is_none());
        assert!(Reaches::new(&octa, None, None, true).ball.is_none());
    }
}
