"""A rollout function for TRL's GRPOTrainer (`rollout_func=`) that plays
negotiator episodes on `negotiator env-server`, one per prompt.

The episode loop (`play_episode`) is plain OpenEnv: reset, send each scene
to the model, step with its whole reply (the server reads it with the
benchmark's protective parser), collect the terminal reward. `rollout_func`
wraps it in the shape TRL expects (token ids of the prompt and the
completions, and the environment's reward as an extra field for a reward
function). `generate(messages) -> str` is yours: vLLM in training; here, any
OpenAI-compatible endpoint.

Run one episode (no training, no GPU):

    negotiator env-server --port 8000 &
    negotiator serve --policy expert --port 8765 &
    pip install openenv requests
    python examples/python/trl_grpo_rollout.py http://127.0.0.1:8000 http://127.0.0.1:8765/v1
"""

import sys

import requests
from openenv import GenericEnvClient


def openai_generate(base_url, model="expert"):
    """`generate(messages)` against an OpenAI-compatible chat endpoint."""

    def generate(messages):
        r = requests.post(f"{base_url}/chat/completions", json={"model": model, "messages": messages}, timeout=120)
        r.raise_for_status()
        return r.json()["choices"][0]["message"]["content"]

    return generate


def play_episode(env_url, generate, scenario="yield_standoff", tier=1, seed=None):
    """One episode as `eval` plays it (the instructions as the system
    message, then one scene per turn, the model's earlier answers kept).
    Returns the conversation, the episode reward and the terminal metadata."""
    with GenericEnvClient(base_url=env_url).sync() as env:
        result = env.reset(scenario=scenario, tier=tier, seed=seed, view="text")
        messages = [{"role": "system", "content": result.observation["instructions"]}]
        while not result.done:
            messages.append({"role": "user", "content": result.observation["scene"]})
            reply = generate(messages)
            messages.append({"role": "assistant", "content": reply})
            result = env.step({"reply": reply})
        return messages, result.reward, result.metadata


def make_rollout_func(env_url, generate, scenario="yield_standoff", tier=1):
    """`rollout_func(prompts, trainer)` for GRPOTrainer: one episode per
    prompt (the prompt text, if it holds a whole number, is the seed).
    Returns prompt and completion token ids and `env_reward`; pass
    `reward_funcs=[lambda completions, env_reward, **kw: env_reward]`."""

    def rollout_func(prompts, trainer):
        tokenizer = trainer.processing_class
        out = {"prompt_ids": [], "completion_ids": [], "logprobs": [], "env_reward": []}
        for prompt in prompts:
            seed = int(prompt) if str(prompt).strip().isdigit() else None
            messages, reward, _ = play_episode(env_url, generate, scenario, tier, seed)
            prompt_text = tokenizer.apply_chat_template(messages[:2], tokenize=False)
            completion_text = "\n".join(m["content"] for m in messages[2:] if m["role"] == "assistant")
            out["prompt_ids"].append(tokenizer(prompt_text)["input_ids"])
            ids = tokenizer(completion_text)["input_ids"]
            out["completion_ids"].append(ids)
            out["logprobs"].append([0.0] * len(ids))
            out["env_reward"].append(reward)
        return out

    return rollout_func


if __name__ == "__main__":
    env_url = sys.argv[1] if len(sys.argv) > 1 else "http://127.0.0.1:8000"
    model_url = sys.argv[2] if len(sys.argv) > 2 else "http://127.0.0.1:8765/v1"
    messages, reward, metadata = play_episode(env_url, openai_generate(model_url), "contested_merge", 2, seed=3)
    print(f"{(len(messages) - 1) // 2} turns, reward {reward:.3f}, outcome {metadata['outcome']}")
