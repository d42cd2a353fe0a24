"""Ready-made nodes for tool-calling agents, as LangGraph's ``langgraph.prebuilt`` has them.

>>> from agentic_core.graph import START, MessagesState, StateGraph
>>> from agentic_core.contracts.messages import AIMessage
>>> def wind(lat: float, lon: float) -> float:
...     '''Wind speed in m/s at a place.'''
...     return 4.2
>>> def model(state: MessagesState) -> dict[str, list[AIMessage]]:
...     if state["messages"][-1].type == "tool":
...         return {"messages": [AIMessage(f"wind is {state['messages'][-1].content} m/s")]}
...     return {"messages": [AIMessage("", tool_calls=[{"name": "wind", "args": {"lat": 1, "lon": 2}, "id": "1"}])]}
>>> builder = StateGraph(MessagesState)
>>> _ = builder.add_node("agent", model).add_node(ToolNode([wind]))
>>> _ = builder.add_edge(START, "agent").add_conditional_edges("agent", tools_condition).add_edge("tools", "agent")
>>> builder.compile().invoke({"messages": [("user", "how windy?")]})["messages"][-1].content
'wind is 4.2 m/s'
"""

from .tool_node import ToolNode, tools_condition

__all__ = ["ToolNode", "tools_condition"]
