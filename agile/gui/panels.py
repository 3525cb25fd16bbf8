"""Read-only panels of the browser viewer: env 0's reward terms over the last steps, and its commands."""

from __future__ import annotations

import numpy as np
import torch

HISTORY_STEPS = 200
PLOT_EVERY_STEPS = 5
"""A plot redrawn every env step would send the whole history 50 times a second; every 5th step is smooth."""
VALUES_EVERY_STEPS = 25
"""The values' text changes its height as the numbers change and the browser lays the panel out again: twice a
second at 50 Hz is readable and keeps a software-rendered page (CI's headless Chromium) responsive."""
SERIES_COLOURS = ("#2563eb", "#dc2626", "#16a34a", "#9333ea", "#ea580c", "#0891b2", "#db2777", "#65a30d",
                  "#4f46e5", "#b45309", "#0d9488", "#be123c")


class RewardPlot:
    """Every reward term of env 0 (weighted, per second: what the term adds to the return divided by dt) over
    the last `HISTORY_STEPS` env steps, one line each, in one plot, and each term's latest value as text under it
    (uPlot's own legend shows values only under the mouse, "--" otherwise). A paused run adds nothing."""

    def __init__(self, server, env, history_steps: int = HISTORY_STEPS):
        from viser import uplot

        self.names = list(env.reward_manager.step_reward)
        self.history = np.full((len(self.names), history_steps), np.nan)
        self.steps = np.arange(-history_steps + 1, 1, dtype=np.float64)
        self._calls = 0
        self._last_step = None
        self.handle = self.values_text = None
        if not self.names:
            return
        series = [uplot.Series(label="step")] + [
            uplot.Series(label=name, stroke=SERIES_COLOURS[i % len(SERIES_COLOURS)], width=1.5)
            for i, name in enumerate(self.names)]
        with server.gui.add_folder("Rewards (env 0)", order=4.0):
            self.handle = server.gui.add_uplot(data=self._data(), series=tuple(series),
                                               scales={"x": uplot.Scale(time=False)}, aspect=1.2,
                                               legend=uplot.Legend(live=False))
            self.values_text = server.gui.add_markdown(self._values_markdown())

    def _data(self) -> tuple[np.ndarray, ...]:
        # uPlot takes no NaN gaps: steps not yet taken show as 0
        return (self.steps, *np.nan_to_num(self.history))

    def latest(self) -> dict[str, float]:
        """Each term's value at the last step (NaN before the first)."""
        return {name: float(self.history[i, -1]) for i, name in enumerate(self.names)}

    def _values_markdown(self) -> str:
        if np.isnan(self.history[:, -1]).all():
            return "no step yet"
        return "  \n".join(f"**{name}** {value:+.3f}" for name, value in self.latest().items())

    def update(self, env) -> None:
        """After an env step: add env 0's terms. Called again without a step (a paused run), it adds nothing."""
        step = int(env.common_step_counter)  # a device tensor, changed in place: compare its value
        if not self.names or step == self._last_step:
            return
        self._last_step = step
        values = torch.stack([env.reward_manager.step_reward[n][0] for n in self.names]).cpu().numpy()
        self.history = np.roll(self.history, -1, axis=1)
        self.history[:, -1] = values
        self._calls += 1
        if self._calls % PLOT_EVERY_STEPS == 0:
            self.handle.data = self._data()
        if self._calls % VALUES_EVERY_STEPS == 0:
            self.values_text.content = self._values_markdown()


class CommandPanel:
    """The active commands of env 0 (each command term's values), refreshed every few steps."""

    def __init__(self, server, env, every_steps: int = 10):
        self.names = list(env.command_manager.terms)
        self.every_steps = every_steps
        self._calls = 0
        self.handle = None
        if self.names:
            with server.gui.add_folder("Commands (env 0)", order=5.0):
                self.handle = server.gui.add_markdown(self._text(env))

    def _text(self, env) -> str:
        lines = []
        for name in self.names:
            values = env.command_manager.get_command(name)[0].cpu().tolist()
            lines.append(f"**{name}**: " + ", ".join(f"{v:+.2f}" for v in values))
        return "  \n".join(lines)

    def update(self, env) -> None:
        self._calls += 1
        if self.handle is not None and self._calls % self.every_steps == 0:
            self.handle.content = self._text(env)
