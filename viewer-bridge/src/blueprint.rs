//! The default layout sent with every recording: the paper's Fig. 3 in Rerun.
//!
//! ```text
//! ┌──────────────────────────────┬─────────────┐
//! │ Map (2D, zoomable)           │ Overview    │
//! │  tabs: Map | Known regions   │ (mini-map)  │
//! │                              ├─────────────┤
//! │                              │ 3D          │
//! ├──────────────────────────────┴──┬──────────┤
//! │ charts (exploration, treasures, │ events   │
//! │ robots, energy, messages)       │          │
//! └─────────────────────────────────┴──────────┘
//! ```

use rerun::blueprint::components::{PanelState, PlayState};
use rerun::blueprint::{
    Blueprint, BlueprintPanel, ContainerLike, Grid, Horizontal, SelectionPanel, Spatial2DView, Spatial3DView, Tabs,
    TextLogView, TimePanel, TimeSeriesView, Vertical,
};

use crate::rerun_observer::TIMELINE;

/// The layout of a simulation recording.
pub fn simulation() -> Blueprint {
    let map = Spatial2DView::new("Map")
        .with_origin("/world")
        .with_contents(["$origin/**", "- /world/known/**"]);
    let known = Spatial2DView::new("Known regions")
        .with_origin("/world")
        .with_contents([
            "/world/obstacles/raster",
            "/world/known/**",
            "/world/robots",
            "/world/home",
        ]);
    let overview = Spatial2DView::new("Overview").with_origin("/world").with_contents([
        "/world/obstacles/raster",
        "/world/explored",
        "/world/home",
        "/world/robots",
        "/world/treasures",
    ]);
    let view3d = Spatial3DView::new("3D").with_origin("/world3d");
    let charts = Grid::new([
        chart("Explored fraction", "exploration"),
        chart("Treasures", "treasures"),
        chart("Robots alive", "robots"),
        chart("Mean energy", "energy"),
        chart("Messages", "messages"),
        chart("Totals", "totals"),
    ])
    .with_grid_columns(3);
    let events = TextLogView::new("Events").with_origin("/events");
    let top = Horizontal::new([
        Tabs::new([map.into(), known.into()]).into(),
        Vertical::new([overview.into(), view3d.into()]).into(),
    ])
    .with_column_shares([2.6, 1.0]);
    let bottom = Horizontal::new([charts.into(), events.into()]).with_column_shares([2.6, 1.0]);
    Blueprint::new(Vertical::new([top.into(), bottom.into()]).with_row_shares([2.2, 1.0]))
        .with_auto_views(false)
        // The views need the room; both side panels open with a click. A recording opens at
        // its end (a live one follows the newest round).
        .with_blueprint_panel(BlueprintPanel::new().with_state(PanelState::Collapsed))
        .with_selection_panel(SelectionPanel::new().with_state(PanelState::Collapsed))
        .with_time_panel(
            TimePanel::new()
                .with_timeline(TIMELINE)
                .with_state(PanelState::Collapsed)
                .with_play_state(PlayState::Following),
        )
}

/// The layout of a map shown alone (`smartteams view`).
pub fn map_only() -> Blueprint {
    let map = Spatial2DView::new("Map").with_origin("/world");
    let view3d = Spatial3DView::new("3D").with_origin("/world3d");
    Blueprint::new(Horizontal::new([map.into(), view3d.into()]).with_column_shares([2.0, 1.0])).with_auto_views(false)
}

fn chart(name: &str, group: &str) -> ContainerLike {
    TimeSeriesView::new(name)
        .with_origin(format!("/metrics/{group}"))
        .into()
}
