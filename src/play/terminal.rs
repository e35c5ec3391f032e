//! The terminal interface of `play`: a loop that takes the run's messages,
//! puts the next turn on the screen, draws it and answers a key, each part
//! in its own function over the screen's state.

use super::endpoint::{Prompt, ToScreen};
use super::screen::{self, Screen};
use super::{HELP_KEYS, Side, episode_over, input};
use ratatui::crossterm::event::{self, Event as Term, KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use std::collections::VecDeque;
use std::sync::mpsc::TryRecvError;
use std::time::{Duration, Instant};

/// Run the terminal interface until the run is over or the person quits.
pub(super) fn run(side: &Side) -> anyhow::Result<()> {
    let mut terminal = ratatui::try_init()?;
    let mut state = State::new(side);
    let result = (|| -> anyhow::Result<()> {
        loop {
            if state.take_messages(side) {
                return Ok(());
            }
            state.show_next_turn(side);
            state.update_status(side);
            terminal.draw(|f| screen::draw(f, &state.screen))?;
            if !event::poll(Duration::from_millis(100))? {
                continue;
            }
            if let Term::Key(key) = event::read()?
                && key.kind == KeyEventKind::Press
            {
                state.on_key(key, side);
            }
        }
    })();
    ratatui::restore();
    result
}

/// What the interface keeps between frames.
struct State {
    screen: Screen,
    /// The turn on the screen, waiting for the person's answer.
    pending: Option<Prompt>,
    /// Turns the run has asked for and the screen has not shown yet.
    queued: VecDeque<Prompt>,
    selected: usize,
    played: usize,
    quitting: bool,
    deadline: Option<Instant>,
    /// An unanswered turn stays open after quitting (see `Side::lines`):
    /// the run is stopped as interrupted, not failed by a dropped answer.
    unanswered: Vec<Prompt>,
}

impl State {
    fn new(side: &Side) -> State {
        State {
            screen: Screen {
                name: side.name.clone(),
                help: true,
                help_text: format!("{}\n\nKeys\n{}", crate::instructions::SYSTEM_PROMPT, HELP_KEYS),
                ..Screen::default()
            },
            pending: None,
            queued: VecDeque::new(),
            selected: 0,
            played: 0,
            quitting: false,
            deadline: None,
            unanswered: Vec::new(),
        }
    }

    /// Take every message the run has sent; true once the run is over.
    fn take_messages(&mut self, side: &Side) -> bool {
        loop {
            match side.from_run.try_recv() {
                Ok(ToScreen::Prompt(p)) => self.queued.push_back(p),
                Ok(ToScreen::TimedOut { held }) => {
                    self.pending = None;
                    self.screen.scene = None;
                    self.screen.flash = Some(format!("time ran out: sent {held}"));
                }
                Ok(ToScreen::Planned { selected, finished }) => {
                    self.selected = selected;
                    self.played = finished;
                }
                Ok(ToScreen::EpisodeOver { key, outcome, reward }) => {
                    self.played += 1;
                    self.screen.notice = Some(episode_over(&key, outcome, reward, side.feedback));
                }
                Ok(ToScreen::RunOver) | Err(TryRecvError::Disconnected) => return true,
                Err(TryRecvError::Empty) => return false,
            }
        }
    }

    /// Put the next queued turn on the screen, once the last one is
    /// answered and any notice has been read.
    fn show_next_turn(&mut self, side: &Side) {
        if self.pending.is_some() || self.screen.notice.is_some() || self.quitting {
            return;
        }
        let Some(mut p) = self.queued.pop_front() else { return };
        self.screen.plan = if side.plan_view { crate::observation::parse_scene(&p.scene).ok() } else { None };
        self.screen.scene = Some(p.scene.clone());
        self.screen.scroll = 0;
        if let Some(shown) = p.shown.take() {
            let _ = shown.send(());
        }
        self.deadline = side.turn_seconds.map(|t| Instant::now() + Duration::from_secs_f64(t));
        self.pending = Some(p);
    }

    /// The top line: which episode, and the clock of a timed turn.
    fn update_status(&mut self, side: &Side) {
        self.screen.progress = if self.quitting {
            "saving...".to_string()
        } else {
            format!("episode {} of {}", (self.played + 1).min(self.selected.max(1)), self.selected)
        };
        self.screen.clock = match (side.turn_seconds, self.deadline.filter(|_| self.pending.is_some())) {
            (Some(_), Some(d)) => {
                Some(format!("{:.0} s left", d.saturating_duration_since(Instant::now()).as_secs_f64().ceil()))
            }
            (Some(t), None) => Some(format!("{t} s per turn")),
            _ => None,
        };
    }

    /// Send `reply` as the answer to the turn on the screen, if there is one.
    fn answer(&mut self, reply: String) -> bool {
        match self.pending.take() {
            Some(p) => {
                let _ = p.answer.send(reply);
                self.screen.flash = None;
                true
            }
            None => false,
        }
    }

    fn on_key(&mut self, key: KeyEvent, side: &Side) {
        let ctrl_c = key.modifiers.contains(KeyModifiers::CONTROL) && key.code == KeyCode::Char('c');
        if self.screen.typing.is_some() && !ctrl_c {
            self.on_typing_key(key.code);
            return;
        }
        let s = &mut self.screen;
        match key.code {
            _ if ctrl_c || key.code == KeyCode::Char('q') => {
                self.quitting = true;
                self.unanswered.extend(self.pending.take());
                side.interrupt.notify_one();
            }
            KeyCode::Char('?') => {
                s.help = !s.help;
                s.scroll = 0;
            }
            KeyCode::Esc | KeyCode::Enter if s.help => s.help = false,
            KeyCode::Enter if s.notice.is_some() => {
                s.notice = None;
                s.scene = None;
            }
            KeyCode::Enter => {
                let reply = s.draft.reply();
                if self.answer(reply) {
                    self.screen.scene = None;
                }
            }
            KeyCode::Char('{') => s.typing = Some("{".to_string()),
            KeyCode::Up | KeyCode::Right => s.draft.adjust(0.1),
            KeyCode::Down | KeyCode::Left => s.draft.adjust(-0.1),
            KeyCode::PageDown => s.scroll = s.scroll.saturating_add(5),
            KeyCode::PageUp => s.scroll = s.scroll.saturating_sub(5),
            KeyCode::Char(c) => {
                if let Some(m) = input::maneuver_key(c) {
                    s.draft.maneuver = m;
                } else if let Some(v) = input::strength_key(c) {
                    s.draft.strength = v;
                }
            }
            _ => {}
        }
    }

    /// A key while a JSON action is being typed.
    fn on_typing_key(&mut self, code: KeyCode) {
        let Some(typing) = self.screen.typing.as_mut() else { return };
        match code {
            KeyCode::Esc => self.screen.typing = None,
            KeyCode::Backspace => {
                typing.pop();
            }
            KeyCode::Enter => {
                let text = self.screen.typing.take().unwrap_or_default();
                self.answer(text);
            }
            KeyCode::Char(c) => typing.push(c),
            _ => {}
        }
    }
}
